// What the scene file knows about each shadow and ambient technique, in one declarative table: its
// name, whether it shadows or occludes, which kinds of caster (volumes, spheres, isosurfaces, planes)
// it takes, which `shadows.*` / `ambient.*` keys it reads, whether it needs the extinction SAT and
// whether it traces rays through spheres (then the renderer builds the Embree BVH). The scene reader
// validates names and warns about keys no chosen technique reads from this table alone;
// registry/registry.cpp builds the techniques it names (tests/test_technique_catalog.cpp checks that
// every key listed changes the image and every other key leaves it untouched). Adding a technique: one
// row here and one line in the registry.
//
// Which technique covers which casters: `shadows.<kind>` when the scene gives it, else
// `shadows.technique` when that takes the kind, else the kind's default (volumes cssm, spheres issm,
// isosurfaces light_pass, planes ray_traced). Each light's transmittance to a point is the product over
// the techniques so chosen (one per distinct name, each built from its kinds of caster only).
#pragma once

#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "penumbra/scene/scene.h"

namespace penumbra {

enum class TechniqueFamily { Shadow, Ambient };

struct TechniqueInfo {
  std::string_view name;
  TechniqueFamily family;
  KindMask casters;                    // the kinds of caster (occluder) it takes
  std::vector<std::string_view> keys;  // keys of `shadows` (Shadow) or `ambient` (Ambient) it reads
  bool extinction_sat = false;         // reads the extinction SAT (and `light_cache.resolution`)
  bool sphere_rays = false;            // traces rays through spheres (needs the BVH)
};

std::span<const TechniqueInfo> technique_catalog();
// The technique of that name, or nullptr.
const TechniqueInfo* find_technique(TechniqueFamily family, std::string_view name);
// Every name of the family ("none" first); those that take casters of `kind`.
std::vector<std::string> technique_names(TechniqueFamily family);
std::vector<std::string> technique_names(TechniqueFamily family, ObjectKind kind);

// The kinds of object in the scene that cast shadows, and those that receive them.
KindMask casting_kinds(const Scene& scene);
KindMask receiving_kinds(const Scene& scene);

// One shadow technique of a light and the kinds of caster it covers.
struct ShadowAssignment {
  std::string technique;
  KindMask casters;
};
// The shadow techniques that cover the scene's casting kinds (see above), in catalogue order of
// their kinds; empty when nothing casts. Throws Error naming `shadows.<kind>` for a technique that
// does not take that kind.
std::vector<ShadowAssignment> shadow_assignments(const Scene& scene);
// The kinds an ambient technique takes that the scene holds (its occluders).
KindMask ambient_occluders(const Scene& scene);

// Whether the scene's techniques read the extinction SAT, whether they need its colour table, and
// whether any traces rays through spheres.
bool needs_extinction_sat(const Scene& scene);
bool needs_extinction_colour(const Scene& scene);
bool needs_sphere_bvh(const Scene& scene);

}  // namespace penumbra
