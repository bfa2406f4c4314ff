// The scene file's shadows, ambient and shading sections: the technique names and keys the catalogue
// (registry/technique_catalog.h) knows, and a note for every key no chosen technique reads.
#include "penumbra/scene_io/scene_sections.h"

#include <algorithm>

#include "penumbra/registry/technique_catalog.h"

namespace penumbra::scene_sections {
namespace {

void check_technique(JsonReader& r, const std::string& name, const std::vector<std::string>& available) {
  if (std::find(available.begin(), available.end(), name) != available.end()) return;
  r.fail("technique", "unknown technique '" + name + "' (expected one of: " + join(available) + ")");
}

}  // namespace

ShadowSettings read_shadows(const nlohmann::json& j) {
  JsonReader r(j, "shadows");
  ShadowSettings s;
  s.technique = r.string("technique", s.technique);
  check_technique(r, s.technique, technique_names(TechniqueFamily::Shadow));
  s.resolution = static_cast<int>(r.integer("resolution", s.resolution, 16, 16384));
  s.offsets = static_cast<int>(r.integer("offsets", s.offsets, 1, 21));
  if (s.offsets != 7 && s.offsets != 13 && s.offsets != 21)
    r.fail("offsets", "value " + std::to_string(s.offsets) + " is not supported (expected 7, 13 or 21, paper §4)");
  s.seed = static_cast<std::uint64_t>(r.integer("seed", static_cast<std::int64_t>(s.seed), 0, INT64_MAX));
  s.nodes = static_cast<int>(r.integer("nodes", s.nodes, 2, 64));
  s.dsm_layout = r.string("dsm_layout", s.dsm_layout);
  if (s.dsm_layout != "per_channel" && s.dsm_layout != "shared_depth")
    r.fail("dsm_layout", "unknown value '" + s.dsm_layout + "' (expected per_channel or shared_depth)");
  s.pcf = static_cast<int>(r.integer("pcf", s.pcf, 0, 16));
  s.bias = r.number("bias", s.bias, -1, 1e6f);
  if (s.bias < 0 && s.bias != -1) r.fail("bias", "must be at least 0 (or -1 for the automatic bias)");
  s.step = r.number("step", s.step, -1, 8);
  if (s.step < 0.05f && s.step != -1) r.fail("step", "must be at least 0.05 voxels (or -1 for the default, one voxel)");
  s.cone_angle = r.number("cone_angle", s.cone_angle, 0, 90);
  if (s.cone_angle >= 90) r.fail("cone_angle", "must be below 90 degrees (the cone's half-angle)");
  s.cone_samples = r.number("cone_samples", s.cone_samples, 1, 4096);
  s.cone_growth = r.number("cone_growth", s.cone_growth, 0, 1);
  s.cone_rays = static_cast<int>(r.integer("cone_rays", s.cone_rays, 1, 4096));
  s.rings = static_cast<int>(r.integer("rings", s.rings, -1, 64));
  s.soft_radius = r.number("soft_radius", s.soft_radius, 0, 1e6f);
  s.soft_exponent = r.number("soft_exponent", s.soft_exponent, 0.01f, 100);
  s.soft_distance = r.number("soft_distance", s.soft_distance, 1e-6f, 1e6f);
  s.light_angle = r.number("light_angle", s.light_angle, 0, 45);
  s.area_rays = static_cast<int>(r.integer("area_rays", s.area_rays, 1, 65536));
  s.light_frustum = r.string("light_frustum", s.light_frustum);
  if (s.light_frustum != "tight" && s.light_frustum != "volume")
    r.fail("light_frustum", "unknown value '" + s.light_frustum + "' (expected tight or volume)");
  for (int i = 0; i < kObjectKinds; ++i) {  // shadows.volumes, .spheres, .isosurfaces, .planes
    const auto kind = static_cast<ObjectKind>(i);
    const std::string key = to_string(kind);
    if (!r.has(key)) continue;
    const std::string name = r.string(key, "");
    const std::vector<std::string> takes = technique_names(TechniqueFamily::Shadow, kind);
    if (std::find(takes.begin(), takes.end(), name) == takes.end())
      r.fail(key, "technique '" + name + "' does not take " + key + " as casters (expected one of: " + join(takes) + ")");
    s.by_kind[static_cast<std::size_t>(i)] = name;
  }
  r.finish();
  return s;
}

AmbientSettings read_ambient(const nlohmann::json& j) {
  JsonReader r(j, "ambient");
  AmbientSettings a;
  a.technique = r.string("technique", a.technique);
  check_technique(r, a.technique, technique_names(TechniqueFamily::Ambient));
  a.shells = static_cast<int>(r.integer("shells", a.shells, 1, 64));
  a.radius = r.number("radius", a.radius, 0, 1);
  if (!(a.radius > 0)) r.fail("radius", "must be positive (a fraction of the volume's longest side, e.g. 0.05)");
  a.bleeding = r.number("bleeding", a.bleeding, 0, 1);
  a.directions = static_cast<int>(r.integer("directions", a.directions, 1, 1024));
  a.max_distance = r.number("max_distance", a.max_distance, 0, 10);
  if (!(a.max_distance > 0)) r.fail("max_distance", "must be positive (a fraction of the spheres' longest side, e.g. 0.7)");
  a.grid = static_cast<int>(r.integer("grid", a.grid, 4, 512));
  a.rays = static_cast<int>(r.integer("rays", a.rays, 1, 65536));
  r.finish();
  return a;
}

// One line for every key of `section` ("shadows" or "ambient") that none of the scene's chosen
// techniques reads: the key, the techniques, and the techniques that would read it.
void note_unread_keys(const nlohmann::json& j, const std::string& section, TechniqueFamily family,
                      const std::vector<std::string>& chosen, std::vector<std::string>& notes) {
  if (!j.is_object()) return;
  for (const auto& [key, value] : j.items()) {
    if (key == "technique" || value.is_null()) continue;
    if (family == TechniqueFamily::Shadow) {  // shadows.volumes, .spheres, ...: read by the reader itself
      bool kind_key = false;
      for (int i = 0; i < kObjectKinds; ++i) kind_key = kind_key || key == to_string(static_cast<ObjectKind>(i));
      if (kind_key) continue;
    }
    bool read = false;
    for (const auto& name : chosen)
      if (const TechniqueInfo* info = find_technique(family, name))
        read = read || std::find(info->keys.begin(), info->keys.end(), key) != info->keys.end();
    if (read) continue;
    std::vector<std::string> readers;
    for (const auto& t : technique_catalog())
      if (t.family == family && std::find(t.keys.begin(), t.keys.end(), key) != t.keys.end()) readers.emplace_back(t.name);
    notes.push_back(section + "." + key + " is not read by " + (chosen.empty() ? std::string("any technique of this scene") : join(chosen)) +
                    "; " + (readers.empty() ? std::string("no technique reads it") : "it is read by: " + join(readers)));
  }
}

ShadingParams read_shading(const nlohmann::json& j) {
  JsonReader r(j, "shading");
  ShadingParams s;
  s.ambient = r.number("ambient", s.ambient, 0, 1);
  s.diffuse = r.number("diffuse", s.diffuse, 0, 1);
  s.specular = r.number("specular", s.specular, 0, 1);
  s.shininess = r.number("shininess", s.shininess, 1, 1000);
  r.finish();
  return s;
}

}  // namespace penumbra::scene_sections
