#include "penumbra/registry/technique_catalog.h"

#include <algorithm>

#include "penumbra/core/error.h"
#include "penumbra/registry/registry.h"

namespace penumbra {

namespace {

constexpr KindMask kVolumes = kind_bit(ObjectKind::Volume);
constexpr KindMask kSpheres = kind_bit(ObjectKind::Spheres);
constexpr KindMask kIsosurfaces = kind_bit(ObjectKind::Isosurface);

// The technique that covers a kind when neither shadows.<kind> nor shadows.technique does.
std::string default_for(ObjectKind kind) {
  switch (kind) {
    case ObjectKind::Volume: return "cssm";
    case ObjectKind::Spheres: return "issm";
    case ObjectKind::Isosurface: return "light_pass";
    case ObjectKind::Plane: return "ray_traced";
  }
  return "none";
}

}  // namespace

std::vector<const TechniqueInfo*> technique_catalog() { return registered_techniques(); }

const TechniqueInfo* find_technique(TechniqueFamily family, std::string_view name) {
  for (const TechniqueInfo* t : registered_techniques())
    if (t->family == family && t->name == name) return t;
  return nullptr;
}

std::vector<std::string> technique_names(TechniqueFamily family) {
  std::vector<std::string> names;
  for (const TechniqueInfo* t : registered_techniques())
    if (t->family == family) names.push_back(t->name);
  return names;
}

std::vector<std::string> technique_names(TechniqueFamily family, ObjectKind kind) {
  std::vector<std::string> names;
  for (const TechniqueInfo* t : registered_techniques())
    if (t->family == family && (t->casters & kind_bit(kind))) names.push_back(t->name);
  return names;
}

const ParamSpec* find_param(TechniqueFamily family, std::string_view key) {
  for (const TechniqueInfo* t : registered_techniques())
    if (t->family == family)
      if (const ParamSpec* p = t->param(key)) return p;
  return nullptr;
}

namespace {
const ParamSpec& declared(TechniqueFamily family, std::string_view key) {
  const ParamSpec* p = find_param(family, key);
  if (!p) throw Error(to_string(family) + "." + std::string(key) + ": no technique declares this key");
  return *p;
}
}  // namespace

double param_number(TechniqueFamily family, const TechniqueParams& params, std::string_view key) {
  return declared(family, key).number(params);
}

std::int64_t param_integer(TechniqueFamily family, const TechniqueParams& params, std::string_view key) {
  return declared(family, key).integer(params);
}

std::vector<const ParamSpec*> family_params(TechniqueFamily family) {
  std::vector<const ParamSpec*> out;
  for (const TechniqueInfo* t : registered_techniques())
    if (t->family == family)
      for (const ParamSpec& p : t->params)
        if (std::none_of(out.begin(), out.end(), [&](const ParamSpec* q) { return q->key == p.key; })) out.push_back(&p);
  return out;
}

KindMask casting_kinds(const Scene& s) {
  KindMask k = 0;
  for (const auto& v : s.volumes)
    if (v.visible && v.casts_shadows) k |= kVolumes;
  for (const auto& p : s.particles)
    if (p.visible && p.casts_shadows) k |= kSpheres;
  for (const auto& i : s.isosurfaces)
    if (i.casts_shadows) k |= kIsosurfaces;
  for (const auto& p : s.planes)
    if (p.casts_shadows) k |= kind_bit(ObjectKind::Plane);
  return k;
}

KindMask receiving_kinds(const Scene& s) {
  KindMask k = 0;
  for (const auto& v : s.volumes)
    if (v.visible && v.receives_shadows) k |= kVolumes;
  for (const auto& p : s.particles)
    if (p.visible && p.receives_shadows) k |= kSpheres;
  for (const auto& i : s.isosurfaces)
    if (i.receives_shadows) k |= kIsosurfaces;
  for (const auto& p : s.planes)
    if (p.receives_shadows) k |= kind_bit(ObjectKind::Plane);
  return k;
}

std::vector<ShadowAssignment> shadow_assignments(const Scene& s) {
  std::vector<ShadowAssignment> out;
  const KindMask casting = casting_kinds(s);
  if (casting == 0) return out;
  for (int i = 0; i < kObjectKinds; ++i) {
    const auto kind = static_cast<ObjectKind>(i);
    if (!(casting & kind_bit(kind))) continue;
    const std::string& chosen = s.shadows.by_kind[static_cast<std::size_t>(i)];
    std::string name;
    if (!chosen.empty()) {
      const TechniqueInfo* t = find_technique(TechniqueFamily::Shadow, chosen);
      if (!t || !(t->casters & kind_bit(kind)))
        throw Error("shadows." + to_string(kind) + ": technique '" + chosen + "' does not take " + to_string(kind) +
                    " as casters (expected one of: " + [&] {
                      std::string all;
                      for (const auto& n : technique_names(TechniqueFamily::Shadow, kind)) all += (all.empty() ? "" : ", ") + n;
                      return all;
                    }() + ")");
      name = chosen;
    } else {
      const TechniqueInfo* main = find_technique(TechniqueFamily::Shadow, s.shadows.technique);
      name = main && (main->casters & kind_bit(kind)) ? s.shadows.technique : default_for(kind);
    }
    if (name == "none") continue;
    auto same = std::find_if(out.begin(), out.end(), [&](const ShadowAssignment& a) { return a.technique == name; });
    if (same != out.end()) same->casters |= kind_bit(kind);
    else out.push_back({name, kind_bit(kind)});
  }
  return out;
}

KindMask ambient_occluders(const Scene& s) {
  const TechniqueInfo* t = find_technique(TechniqueFamily::Ambient, s.ambient.technique);
  if (!t || s.ambient.technique == "none") return 0;
  KindMask present = 0;
  for (const auto& v : s.volumes)
    if (v.visible) present |= kVolumes;
  if (s.has_particles()) present |= kSpheres;
  if (!s.isosurfaces.empty()) present |= kIsosurfaces;
  if (!s.planes.empty()) present |= kind_bit(ObjectKind::Plane);
  return t->casters & present;
}

bool needs_extinction_sat(const Scene& scene) {
  for (const auto& a : shadow_assignments(scene)) {
    const TechniqueInfo* t = find_technique(TechniqueFamily::Shadow, a.technique);
    if (t && t->needs.extinction_sat && (a.casters & kVolumes)) return true;
  }
  const TechniqueInfo* ambient = find_technique(TechniqueFamily::Ambient, scene.ambient.technique);
  return ambient && ambient->needs.extinction_sat;
}

bool needs_extinction_colour(const Scene& scene) {
  if (!needs_extinction_sat(scene)) return false;
  const TechniqueInfo* ambient = find_technique(TechniqueFamily::Ambient, scene.ambient.technique);
  const ParamSpec* bleeding = ambient ? ambient->param("bleeding") : nullptr;  // colour bleeding reads the SAT's colour
  return bleeding && bleeding->number(scene.ambient.params) > 0;
}

namespace {
// Whether a shadow technique that casts the spheres has the need `need`.
bool sphere_shadows_need(const Scene& scene, bool TechniqueNeeds::*need) {
  for (const auto& a : shadow_assignments(scene)) {
    const TechniqueInfo* t = find_technique(TechniqueFamily::Shadow, a.technique);
    if (t && t->needs.*need && (a.casters & kSpheres)) return true;
  }
  return false;
}
}  // namespace

bool needs_sphere_bvh(const Scene& scene) {
  if (!scene.has_particles()) return false;
  if (scene.sphere_rasterizer == SphereRasterizer::Embree || sphere_shadows_need(scene, &TechniqueNeeds::sphere_rays)) return true;
  const TechniqueInfo* ambient = find_technique(TechniqueFamily::Ambient, scene.ambient.technique);
  return ambient && ambient->needs.sphere_rays && (ambient_occluders(scene) & kSpheres);
}

bool needs_sphere_order(const Scene& scene) {
  if (!scene.has_particles()) return false;
  return scene.sphere_rasterizer == SphereRasterizer::Splat || sphere_shadows_need(scene, &TechniqueNeeds::sphere_order);
}

}  // namespace penumbra
