#include "penumbra/particles/particle_registry.h"

#include "penumbra/core/error.h"
#include "penumbra/particles/implicit_sphere_shadow_map.h"
#include "penumbra/particles/particle_ambient_occlusion.h"
#include "penumbra/particles/ray_traced_spheres.h"

namespace penumbra {

bool needs_sphere_bvh(const Scene& scene) {
  return scene.shadows.technique == "ray_traced" || scene.ambient.technique == "ray_traced_ao";
}

std::unique_ptr<SphereShadowTechnique> make_sphere_shadow_technique(const ShadowSettings& s) {
  if (s.technique == "none") return std::make_unique<NoSphereShadows>();
  if (s.technique == "issm")
    return std::make_unique<ImplicitSphereShadowMap>(
        IssmParams{s.resolution, std::max(s.rings, 0), s.soft_radius, s.soft_exponent, s.soft_distance});
  if (s.technique == "ray_traced") return std::make_unique<RayTracedSphereShadows>(s.light_angle, s.area_rays);
  throw Error("shadows.technique: '" + s.technique + "' is not a technique for spheres (expected none, issm or ray_traced)");
}

std::unique_ptr<ParticleAmbientTechnique> make_particle_ambient_technique(const AmbientSettings& s) {
  if (s.technique == "none") return nullptr;
  if (s.technique == "particle_ao") return std::make_unique<ParticleAmbientOcclusion>(s);
  if (s.technique == "ray_traced_ao") return std::make_unique<RayTracedAmbientOcclusion>(s.max_distance, s.rays);
  throw Error("ambient.technique: '" + s.technique + "' is not a technique for spheres (expected none, particle_ao or ray_traced_ao)");
}

}  // namespace penumbra
