#include "penumbra/render/frame_settings.h"

#include <algorithm>
#include <cmath>

#include "penumbra/accel/extinction_sat.h"
#include "penumbra/lighting/shared_params.h"
#include "penumbra/registry/technique_catalog.h"

namespace penumbra {
namespace {

// A preview's light structures aim at this much build time, all lights together.
constexpr double kPreviewShadowTargetMs = 20;

}  // namespace

Scene preview_settings(const Scene& scene, double full_shadow_ms) {
  Scene s = scene;
  // every key the techniques declare with a role a preview coarsens, at its value or default
  auto coarsen = [&](TechniqueFamily family, TechniqueParams& params) {
    for (const ParamSpec* p : family_params(family)) {
      switch (p->role) {
        case ParamRole::MapSide: {
          const auto full = static_cast<int>(p->integer(params));
          int side = full / 4;
          if (full_shadow_ms > 0) side = std::min(side, static_cast<int>(full * std::sqrt(kPreviewShadowTargetMs / full_shadow_ms)));
          params.set(p->key, std::min(full, std::max(64, side)));
          break;
        }
        case ParamRole::LightStep: params.set(p->key, 2.0 * light_step_voxels(params)); break;
        case ParamRole::RayCount: params.set(p->key, std::max<std::int64_t>(1, p->integer(params) / 4)); break;
        case ParamRole::Plain:
        case ParamRole::Seed: break;
      }
    }
  };
  coarsen(TechniqueFamily::Shadow, s.shadows.params);
  coarsen(TechniqueFamily::Ambient, s.ambient.params);
  s.light_cache.resolution = std::max(kMinSatResolution, s.light_cache.resolution / 2);
  return s;  // the eye step: PreparedVolume keeps a preview table
}

const ParamSpec* seed_param(const Scene& s) {
  for (const ShadowAssignment& a : shadow_assignments(s))
    if (const TechniqueInfo* t = find_technique(TechniqueFamily::Shadow, a.technique))
      for (const ParamSpec& p : t->params)
        if (p.role == ParamRole::Seed) return &p;
  return nullptr;
}

}  // namespace penumbra
