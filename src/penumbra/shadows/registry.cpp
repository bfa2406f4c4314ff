#include "penumbra/shadows/registry.h"

#include "penumbra/core/error.h"
#include "penumbra/scene/technique_catalog.h"
#include "penumbra/shadows/cssm.h"
#include "penumbra/shadows/deep_shadow_map.h"
#include "penumbra/shadows/ray_traced.h"
#include "penumbra/shadows/sat_cone.h"
#include "penumbra/shadows/shadow_map.h"
#include "penumbra/shadows/volume_ambient_occlusion.h"

namespace penumbra {

std::unique_ptr<ShadowTechnique> make_shadow_technique(const ShadowSettings& s) {
  if (s.technique == "none") return std::make_unique<NoShadows>();
  if (s.technique == "shadow_map") return std::make_unique<ClassicShadowMap>(s);
  if (s.technique == "deep_shadow_map") return std::make_unique<DeepShadowMap>(s);
  if (s.technique == "cssm") return std::make_unique<ColoredStochasticShadowMap>(s);
  if (s.technique == "ray_traced") return std::make_unique<RayTracedShadows>();
  if (s.technique == "sat_cone") return std::make_unique<SatConeShadows>(s);
  if (s.technique == "sampled_cone") return std::make_unique<SampledConeShadows>(s);
  std::string known;
  for (const auto& n : technique_names(TechniqueFamily::Shadow, SceneKind::Volume)) known += (known.empty() ? "" : ", ") + n;
  throw Error("shadows.technique: unknown technique '" + s.technique + "' (expected one of: " + known + ")");
}

std::unique_ptr<AmbientTechnique> make_ambient_technique(const AmbientSettings& s) {
  if (s.technique == "none") return nullptr;
  if (s.technique == "sat_shells") return std::make_unique<SatShellsAmbient>(s);
  if (s.technique == "sampled_ao") return std::make_unique<SampledAmbientOcclusion>(s);
  std::string known;
  for (const auto& n : technique_names(TechniqueFamily::Ambient, SceneKind::Volume)) known += (known.empty() ? "" : ", ") + n;
  throw Error("ambient.technique: unknown technique '" + s.technique + "' (expected one of: " + known + ")");
}

}  // namespace penumbra
