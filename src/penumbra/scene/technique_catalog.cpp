#include "penumbra/scene/technique_catalog.h"

#include <algorithm>

#include "penumbra/scene/scene.h"

namespace penumbra {

std::span<const TechniqueInfo> technique_catalog() {
  using F = TechniqueFamily;
  using K = SceneKind;
  // Every key a technique's constructor, build or query reads (docs/scene-file.md describes each key).
  static const std::vector<TechniqueInfo> catalog{
      {"none", F::Shadow, K::Volume, {}},
      {"shadow_map", F::Shadow, K::Volume, {"resolution", "bias", "step", "pcf"}},
      {"deep_shadow_map", F::Shadow, K::Volume, {"resolution", "bias", "step", "nodes", "dsm_layout"}},
      {"cssm", F::Shadow, K::Volume, {"resolution", "bias", "step", "offsets", "seed"}},
      {"ray_traced", F::Shadow, K::Volume, {"step"}},
      {"sat_cone", F::Shadow, K::Volume, {"cone_angle", "cone_samples", "cone_growth"}, true},
      {"sampled_cone", F::Shadow, K::Volume, {"step", "cone_angle", "cone_rays"}},
      {"none", F::Shadow, K::Spheres, {}},
      {"issm", F::Shadow, K::Spheres, {"resolution", "rings", "soft_radius", "soft_exponent", "soft_distance"}},
      {"ray_traced", F::Shadow, K::Spheres, {"light_angle", "area_rays"}},
      {"none", F::Shadow, K::Isosurface, {}},
      {"light_pass", F::Shadow, K::Isosurface, {"resolution", "bias", "light_frustum"}},
      {"ray_traced", F::Shadow, K::Isosurface, {}},
      {"none", F::Ambient, K::Volume, {}},
      {"sat_shells", F::Ambient, K::Volume, {"shells", "radius", "bleeding"}, true},
      {"sampled_ao", F::Ambient, K::Volume, {"radius", "bleeding"}, true},
      {"none", F::Ambient, K::Spheres, {}},
      {"particle_ao", F::Ambient, K::Spheres, {"directions", "max_distance", "grid"}},
      {"ray_traced_ao", F::Ambient, K::Spheres, {"max_distance", "rays"}},
      {"none", F::Ambient, K::Isosurface, {}},
  };
  return catalog;
}

std::string to_string(SceneKind kind) {
  switch (kind) {
    case SceneKind::Volume: return "volume";
    case SceneKind::Spheres: return "sphere";
    case SceneKind::Isosurface: return "isosurface";
  }
  return "?";
}

SceneKind scene_kind(const Scene& scene) {
  if (scene.has_isosurfaces()) return SceneKind::Isosurface;
  if (scene.has_particles()) return SceneKind::Spheres;
  return SceneKind::Volume;
}

const TechniqueInfo* find_technique(TechniqueFamily family, SceneKind kind, std::string_view name) {
  for (const auto& t : technique_catalog())
    if (t.family == family && t.kind == kind && t.name == name) return &t;
  return nullptr;
}

std::vector<std::string> technique_names(TechniqueFamily family, SceneKind kind) {
  std::vector<std::string> names;
  for (const auto& t : technique_catalog())
    if (t.family == family && t.kind == kind) names.emplace_back(t.name);
  return names;
}

std::vector<std::string> technique_names(TechniqueFamily family) {
  std::vector<std::string> names;
  for (const auto& t : technique_catalog())
    if (t.family == family && std::find(names.begin(), names.end(), t.name) == names.end()) names.emplace_back(t.name);
  return names;
}

bool needs_extinction_sat(const Scene& scene) {
  const SceneKind kind = scene_kind(scene);
  const TechniqueInfo* shadow = find_technique(TechniqueFamily::Shadow, kind, scene.shadows.technique);
  const TechniqueInfo* ambient = find_technique(TechniqueFamily::Ambient, kind, scene.ambient.technique);
  return (shadow && shadow->extinction_sat) || (ambient && ambient->extinction_sat);
}

bool needs_extinction_colour(const Scene& scene) {
  return needs_extinction_sat(scene) && scene.ambient.technique != "none" && scene.ambient.bleeding > 0;
}

}  // namespace penumbra
