// The sections of the scene-file reader (scene_file.h), one file each: read_camera_lights_planes.cpp,
// read_volumes.cpp (and isosurfaces), read_particles.cpp, read_techniques.cpp (shadows, ambient,
// shading), read_common.cpp (what they share). scene_file.cpp reads the document and calls them in
// order. Internal to scene_io: every function names the key it fails on (JsonReader).
#pragma once

#include <nlohmann/json.hpp>

#include <initializer_list>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "penumbra/registry/technique_catalog.h"
#include "penumbra/scene/scene.h"
#include "penumbra/scene_io/json_reader.h"
#include "penumbra/scene_io/scene_file.h"

namespace penumbra::scene_sections {

// shared (read_common.cpp)
std::string join(const std::vector<std::string>& names);
std::string resolve(const std::string& base_dir, const std::string& file);
void read_shadow_flags(JsonReader& r, ShadowFlags& f);
std::string data_key(const nlohmann::json& j, const std::string& base_dir, std::initializer_list<const char*> keys, bool all_but = false);
void require_one_source(JsonReader& r);

// The in-memory data that `"array"` names, or an Error naming the key.
template <class Data>
std::shared_ptr<const Data> named_array(JsonReader& r, const SceneArrays* arrays, const std::map<std::string, std::shared_ptr<const Data>> SceneArrays::*kind,
                                        const char* what) {
  const std::string name = r.required_string("array");
  if (!arrays)
    r.fail("array", "names data held in memory by the Python package's builders; a scene file gives 'file' or 'procedural'");
  const auto& known = arrays->*kind;
  const auto it = known.find(name);
  if (it == known.end()) {
    std::string names;
    for (const auto& k : known) names += (names.empty() ? "" : ", ") + k.first;
    r.fail("array", "no " + std::string(what) + " array named \"" + name + "\" (known: " + (names.empty() ? "none" : names) + ")");
  }
  return it->second;
}

// the sections
Camera read_camera(const nlohmann::json& j, const Box3& bounds);
Light read_light(const nlohmann::json& j, const std::string& path, const Box3& bounds);
Plane read_plane(const nlohmann::json& j, const std::string& path);
ClipPlanes read_clip_planes(const nlohmann::json& j, const std::string& path);
Plane read_slice(const nlohmann::json& j, const std::string& path, const std::vector<VolumeObject>& volumes,
                 const std::string& base_dir);
// `budget_left`: what is left of the scene's memory_budget (Scene::memory_budget) for this volume and
// those after it, less what this one holds once read; null: no budget.
VolumeObject read_volume(const nlohmann::json& j, const std::string& path, const std::string& base_dir, const SceneReadOptions& options,
                         std::size_t time, std::uint64_t* budget_left = nullptr);
IsosurfaceObject read_isosurface(const nlohmann::json& j, const std::string& path, const std::vector<VolumeObject>& volumes);
// `files`: where the particle files read are kept, so that entries naming one file read it once (the
// scene's cache, or one for the scene being read when there is none).
ParticleObject read_particles(const nlohmann::json& j, const std::string& path, const std::string& base_dir,
                              const SceneReadOptions& options, std::size_t time, SceneDataCache& files);
ShadowSettings read_shadows(const nlohmann::json& j);
AmbientSettings read_ambient(const nlohmann::json& j);
void note_unread_keys(const nlohmann::json& j, const std::string& section, TechniqueFamily family,
                      const std::vector<std::string>& chosen, std::vector<std::string>& notes);
ShadingParams read_shading(const nlohmann::json& j);

}  // namespace penumbra::scene_sections
