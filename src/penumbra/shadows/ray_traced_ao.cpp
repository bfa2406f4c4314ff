#include "penumbra/shadows/ray_traced_ao.h"

#include "penumbra/lighting/shared_params.h"
#include "penumbra/shadows/ray_sampling.h"

namespace penumbra {

void RayTracedAmbientOcclusion::build(const ShadowCasters& occluders) {
  occluders_ = &occluders;
  const Vec3 e = occluders.bounds().empty() ? Vec3{1, 1, 1} : occluders.bounds().extent();
  max_distance_ = max_distance_fraction_ * std::max(e.x, std::max(e.y, e.z));
}

void RayTracedAmbientOcclusion::ambient(std::span<const Vec3> points, std::span<Rgb> out) const {
  for (std::size_t k = 0; k < points.size(); ++k) {
    float r1, r2;
    pattern_rotation(points[k], r1, r2);
    Rgb sum(0.0f);
    for (int i = 0; i < rays_; ++i) {
      float u1, u2;
      lattice_sample(i, rays_, r1, r2, u1, u2);
      sum += occluders_->transmittance(Ray{points[k], sphere_direction(u1, u2)}, 0, max_distance_);
    }
    out[k] = sum * (1.0f / static_cast<float>(rays_));
  }
}

void RayTracedAmbientOcclusion::ambient(std::span<const SurfacePoint> points, std::span<Rgb> out) const {
  for (std::size_t k = 0; k < points.size(); ++k) {
    const SurfacePoint& sp = points[k];
    const Vec3 origin = occluders_->ray_origin(sp, sp.normal);
    const Frame frame = Frame::from_w(sp.normal);
    float r1, r2;
    pattern_rotation(sp.position, r1, r2);
    Rgb sum(0.0f);
    for (int i = 0; i < rays_; ++i) {
      float u1, u2;
      lattice_sample(i, rays_, r1, r2, u1, u2);
      sum += occluders_->transmittance(Ray{origin, frame.to_world(cosine_direction(u1, u2))}, 0, max_distance_);
    }
    out[k] = sum * (1.0f / static_cast<float>(rays_));
  }
}

namespace {
const ParamSpec kHemisphereRays = integer_param("rays", 64, 1, 65536, "rays", "hemisphere rays per point", ParamRole::RayCount);
}  // namespace

const TechniqueInfo& ray_traced_ao_technique() {
  static const TechniqueInfo info{
      "ray_traced_ao", TechniqueFamily::Ambient, kAllKinds,
      "exact: hemisphere rays through every occluder, coloured where they cross a translucent volume (the reference)",
      {kAoMaxDistance, kHemisphereRays},
      {.sphere_rays = true},
      {},
      [](const TechniqueParams& p) -> std::unique_ptr<AmbientTechnique> {
        return std::make_unique<RayTracedAmbientOcclusion>(static_cast<float>(kAoMaxDistance.number(p)), static_cast<int>(kHemisphereRays.integer(p)));
      }};
  return info;
}

const TechniqueInfo& no_ambient_technique() {
  static const TechniqueInfo info{"none", TechniqueFamily::Ambient, kAllKinds, "no ambient occlusion", {}, {}, {},
                                  [](const TechniqueParams&) -> std::unique_ptr<AmbientTechnique> { return nullptr; }};
  return info;
}

}  // namespace penumbra
