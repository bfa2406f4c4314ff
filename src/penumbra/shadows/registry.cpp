#include "penumbra/shadows/registry.h"

#include "penumbra/core/error.h"
#include "penumbra/shadows/cssm.h"
#include "penumbra/shadows/deep_shadow_map.h"
#include "penumbra/shadows/ray_traced.h"
#include "penumbra/shadows/shadow_map.h"

namespace penumbra {

std::vector<std::string> shadow_technique_names() {
  return {"none", "shadow_map", "deep_shadow_map", "cssm", "ray_traced"};
}

std::vector<std::string> planned_shadow_technique_names() { return {"sat_cone", "issm", "light_pass"}; }

std::unique_ptr<ShadowTechnique> make_shadow_technique(const ShadowSettings& s) {
  if (s.technique == "none") return std::make_unique<NoShadows>();
  if (s.technique == "shadow_map") return std::make_unique<ClassicShadowMap>(s);
  if (s.technique == "deep_shadow_map") return std::make_unique<DeepShadowMap>(s);
  if (s.technique == "cssm") return std::make_unique<ColoredStochasticShadowMap>(s);
  if (s.technique == "ray_traced") return std::make_unique<RayTracedShadows>();
  std::string known;
  for (const auto& n : shadow_technique_names()) known += (known.empty() ? "" : ", ") + n;
  throw Error("shadows.technique: unknown technique '" + s.technique + "' (expected one of: " + known + ")");
}

}  // namespace penumbra
