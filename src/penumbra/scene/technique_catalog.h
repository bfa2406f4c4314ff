// What the scene file knows about each shadow and ambient technique, in one declarative table: its
// name, whether it shadows or occludes, which kind of scene it serves (volume, sphere or isosurface
// scenes), which `shadows.*` / `ambient.*` keys it reads, and whether it needs the extinction SAT.
// The scene reader validates names and warns about keys the chosen technique does not read from this
// table alone; the registries in shadows/, particles/ and isosurface/ build the techniques it names
// (tests/test_technique_catalog.cpp checks that every key listed changes the image and every other
// key leaves it untouched). Adding a technique: one row here and one line in its registry.
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <vector>

namespace penumbra {

struct Scene;

enum class TechniqueFamily { Shadow, Ambient };
// The kind of scene a technique serves: a scene with isosurfaces takes the isosurface techniques, one
// with particles the sphere techniques, any other the volume techniques.
enum class SceneKind { Volume, Spheres, Isosurface };
std::string to_string(SceneKind kind);  // "volume", "sphere", "isosurface"
SceneKind scene_kind(const Scene& scene);

struct TechniqueInfo {
  std::string_view name;
  TechniqueFamily family;
  SceneKind kind;
  std::vector<std::string_view> keys;  // keys of `shadows` (Shadow) or `ambient` (Ambient) it reads
  bool extinction_sat = false;         // reads the extinction SAT (and `light_cache.resolution`)
};

std::span<const TechniqueInfo> technique_catalog();
// The technique of that name for that kind of scene, or nullptr.
const TechniqueInfo* find_technique(TechniqueFamily family, SceneKind kind, std::string_view name);
// Names for one kind of scene ("none" first), and names for any kind (each once).
std::vector<std::string> technique_names(TechniqueFamily family, SceneKind kind);
std::vector<std::string> technique_names(TechniqueFamily family);

// Whether the scene's techniques read the extinction SAT, and whether they need its colour table.
bool needs_extinction_sat(const Scene& scene);
bool needs_extinction_colour(const Scene& scene);

}  // namespace penumbra
