// The exact ambient-occlusion reference for every kind of occluder at once: `rays` rays from each
// receiver, each passing the transmittance of the colour model through the volumes and stopped by
// spheres, isosurfaces and planes (ShadowCasters::transmittance), up to `max_distance`; the ambient
// factor is their mean. A surface point casts cosine-distributed rays over the hemisphere of its
// normal (from just off its own surface); a volume sample, which has no normal, uniform rays over the
// whole sphere. Sample directions are a fixed stratified set rotated per receiver by a hash of its
// position (ray_sampling.h), so results are deterministic and the same for any thread count.
//
// | parameter            | default | meaning                                                  |
// | ambient.max_distance | 0.7     | reach, a fraction of the occluders' longest side           |
// | ambient.rays         | 64      | rays per point                                             |
#pragma once

#include "penumbra/lighting/ambient_technique.h"
#include "penumbra/lighting/technique_info.h"

namespace penumbra {

const TechniqueInfo& ray_traced_ao_technique();
const TechniqueInfo& no_ambient_technique();  // "none"

class RayTracedAmbientOcclusion final : public AmbientTechnique {
public:
  using AmbientTechnique::ambient;
  RayTracedAmbientOcclusion(float max_distance_fraction, int rays) : max_distance_fraction_(max_distance_fraction), rays_(rays) {}
  void build(const ShadowCasters& occluders) override;
  void ambient(std::span<const Vec3> points, std::span<Rgb> out) const override;
  void ambient(std::span<const SurfacePoint> points, std::span<Rgb> out) const override;
  std::size_t memory_bytes() const override { return 0; }
  std::string_view name() const override { return "ray_traced_ao"; }

private:
  float max_distance_fraction_;  // of the occluders' bounding box's longest side
  int rays_;
  const ShadowCasters* occluders_ = nullptr;
  float max_distance_ = 1;
};

}  // namespace penumbra
