#include "penumbra/isosurface/iso_registry.h"

#include "penumbra/core/error.h"
#include "penumbra/isosurface/light_pass.h"
#include "penumbra/isosurface/ray_traced_isosurface.h"

namespace penumbra {

std::unique_ptr<IsoShadowTechnique> make_isosurface_shadow_technique(const ShadowSettings& s) {
  if (s.technique == "none") return std::make_unique<NoIsosurfaceShadows>();
  if (s.technique == "ray_traced") return std::make_unique<RayTracedIsosurfaceShadows>();
  if (s.technique == "light_pass")
    return std::make_unique<LightPass>(LightPassSettings{s.resolution, light_frustum_from_string(s.light_frustum), s.bias});
  throw Error("shadows.technique: '" + s.technique + "' is not an isosurface technique (expected none, light_pass or ray_traced)");
}

}  // namespace penumbra
