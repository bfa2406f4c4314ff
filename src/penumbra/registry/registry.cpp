#include "penumbra/registry/registry.h"

#include <algorithm>
#include <mutex>

#include "penumbra/core/error.h"
#include "penumbra/isosurface/light_pass.h"
#include "penumbra/particles/implicit_sphere_shadow_map.h"
#include "penumbra/particles/particle_ambient_occlusion.h"
#include "penumbra/registry/technique_catalog.h"
#include "penumbra/shadows/cssm.h"
#include "penumbra/shadows/deep_shadow_map.h"
#include "penumbra/shadows/ray_traced.h"
#include "penumbra/shadows/ray_traced_ao.h"
#include "penumbra/shadows/sat_cone.h"
#include "penumbra/shadows/shadow_map.h"
#include "penumbra/shadows/volume_ambient_occlusion.h"

namespace penumbra {
namespace {

// The built-in techniques, one line each.
std::vector<const TechniqueInfo*> built_in() {
  return {&no_shadows_technique(),
          &shadow_map_technique(),
          &deep_shadow_map_technique(),
          &cssm_technique(),
          &ray_traced_technique(),
          &sat_cone_technique(),
          &sampled_cone_technique(),
          &issm_technique(),
          &light_pass_technique(),
          &no_ambient_technique(),
          &sat_shells_technique(),
          &sampled_ao_technique(),
          &particle_ao_technique(),
          &ray_traced_ao_technique()};
}

struct Registry {
  std::mutex mutex;
  std::vector<const TechniqueInfo*> techniques = built_in();
  std::vector<const TechniqueInfo*> built_in_techniques = techniques;
};

Registry& registry() {
  static Registry r;
  return r;
}

std::string known(TechniqueFamily family) {
  std::string all;
  for (const auto& n : technique_names(family)) all += (all.empty() ? "" : ", ") + n;
  return all;
}

}  // namespace

std::vector<const TechniqueInfo*> registered_techniques() {
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  return r.techniques;
}

void register_technique(const TechniqueInfo& info) {
  const std::string what = to_string(info.family) + " technique '" + info.name + "'";
  if (info.name.empty()) throw Error("register_technique: a technique needs a name");
  if (info.family == TechniqueFamily::Shadow ? !info.make_shadow : !info.make_ambient)
    throw Error("register_technique: " + what + " has no factory");
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  for (const TechniqueInfo* t : r.techniques) {
    if (t->family != info.family) continue;
    if (t->name == info.name) throw Error("register_technique: " + what + " is registered already");
    for (const ParamSpec& p : info.params)
      if (const ParamSpec* other = t->param(p.key); other && !(*other == p))
        throw Error("register_technique: " + what + " declares " + to_string(info.family) + "." + p.key + " unlike '" + t->name +
                    "' does (a key means one thing to every technique of its family)");
  }
  // after the last of its family: shadows stay before ambient techniques
  const auto after = std::find_if(r.techniques.rbegin(), r.techniques.rend(), [&](const TechniqueInfo* t) { return t->family == info.family; });
  r.techniques.insert(after.base(), &info);
}

bool unregister_technique(TechniqueFamily family, const std::string& name) {
  Registry& r = registry();
  std::lock_guard lock(r.mutex);
  const auto it = std::find_if(r.techniques.begin(), r.techniques.end(), [&](const TechniqueInfo* t) { return t->family == family && t->name == name; });
  if (it == r.techniques.end() || std::count(r.built_in_techniques.begin(), r.built_in_techniques.end(), *it) > 0) return false;
  r.techniques.erase(it);
  return true;
}

std::unique_ptr<ShadowTechnique> make_shadow_technique(const std::string& name, const ShadowSettings& s) {
  const TechniqueInfo* t = find_technique(TechniqueFamily::Shadow, name);
  if (!t) throw Error("shadows.technique: unknown technique '" + name + "' (expected one of: " + known(TechniqueFamily::Shadow) + ")");
  return t->make_shadow(s.params);
}

std::unique_ptr<AmbientTechnique> make_ambient_technique(const AmbientSettings& s) {
  const TechniqueInfo* t = find_technique(TechniqueFamily::Ambient, s.technique);
  if (!t) throw Error("ambient.technique: unknown technique '" + s.technique + "' (expected one of: " + known(TechniqueFamily::Ambient) + ")");
  return t->make_ambient(s.params);
}

}  // namespace penumbra
