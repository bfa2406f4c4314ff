#include "penumbra/registry/registry.h"

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

std::string known(TechniqueFamily family) {
  std::string all;
  for (const auto& n : technique_names(family)) all += (all.empty() ? "" : ", ") + n;
  return all;
}

}  // namespace

std::unique_ptr<ShadowTechnique> make_shadow_technique(const std::string& name, const ShadowSettings& s) {
  if (name == "none") return std::make_unique<NoShadows>();
  if (name == "shadow_map") return std::make_unique<ClassicShadowMap>(s);
  if (name == "deep_shadow_map") return std::make_unique<DeepShadowMap>(s);
  if (name == "cssm") return std::make_unique<ColoredStochasticShadowMap>(s);
  if (name == "ray_traced") return std::make_unique<RayTracedShadows>(s.light_angle, s.area_rays);
  if (name == "sat_cone") return std::make_unique<SatConeShadows>(s);
  if (name == "sampled_cone") return std::make_unique<SampledConeShadows>(s);
  if (name == "issm")
    return std::make_unique<ImplicitSphereShadowMap>(IssmParams{s.resolution, s.rings, s.soft_radius, s.soft_exponent, s.soft_distance});
  if (name == "light_pass")
    return std::make_unique<LightPass>(LightPassSettings{s.resolution, light_frustum_from_string(s.light_frustum), s.bias});
  throw Error("shadows.technique: unknown technique '" + name + "' (expected one of: " + known(TechniqueFamily::Shadow) + ")");
}

std::unique_ptr<AmbientTechnique> make_ambient_technique(const AmbientSettings& s) {
  if (s.technique == "none") return nullptr;
  if (s.technique == "sat_shells") return std::make_unique<SatShellsAmbient>(s);
  if (s.technique == "sampled_ao") return std::make_unique<SampledAmbientOcclusion>(s);
  if (s.technique == "particle_ao") return std::make_unique<ParticleAmbientOcclusion>(s);
  if (s.technique == "ray_traced_ao") return std::make_unique<RayTracedAmbientOcclusion>(s.max_distance, s.rays);
  throw Error("ambient.technique: unknown technique '" + s.technique + "' (expected one of: " + known(TechniqueFamily::Ambient) + ")");
}

}  // namespace penumbra
