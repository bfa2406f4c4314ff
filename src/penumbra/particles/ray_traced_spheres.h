// Exact references for the particle techniques, traced through Embree (SphereBvh).
//  - RayTracedSphereShadows: hard shadows by one shadow ray per receiver; soft shadows of a round light
//    of angular radius `light_angle` (seen from the scene centre for point and spot lights) by `rays`
//    shadow rays spread uniformly over the light's solid angle — the light fraction is the share of
//    unblocked rays.
//  - RayTracedAmbientOcclusion: Monte-Carlo ambient occlusion, `rays` cosine-distributed hemisphere rays
//    around the normal, each blocked by a sphere closer than `max_distance`: the unblocked fraction.
// Sample directions are a fixed stratified set rotated per receiver by a hash of its position, so
// results are deterministic and the same for any thread count.
#pragma once

#include "penumbra/particles/sphere_shadow_technique.h"

namespace penumbra {

class RayTracedSphereShadows final : public SphereShadowTechnique {
public:
  RayTracedSphereShadows(float light_angle_deg, int rays) : light_angle_deg_(light_angle_deg), rays_(rays) {}
  void build(const ParticleScene& scene, const Light& light) override;
  void light_fraction(std::span<const SurfacePoint> points, std::span<float> out) const override;
  std::size_t memory_bytes() const override { return 0; }  // the shared BVH is counted by the renderer
  std::string_view name() const override { return "ray_traced"; }

private:
  float light_angle_deg_;
  int rays_;
  const SphereBvh* bvh_ = nullptr;
  const ParticleSet* particles_ = nullptr;
  Light light_;
  float tan_light_radius_ = 0;  // tangent of the light's angular radius
  float epsilon_ = 1e-4f;       // offset of ray origins off the surface
  Vec3 scene_center_;
};

class RayTracedAmbientOcclusion final : public ParticleAmbientTechnique {
public:
  RayTracedAmbientOcclusion(float max_distance_fraction, int rays) : max_distance_fraction_(max_distance_fraction), rays_(rays) {}
  void build(const ParticleScene& scene) override;
  void ambient(std::span<const SurfacePoint> points, std::span<float> out) const override;
  std::size_t memory_bytes() const override { return 0; }
  std::string_view name() const override { return "ray_traced_ao"; }

private:
  float max_distance_fraction_;  // of the spheres' bounding box's longest side
  int rays_;
  const SphereBvh* bvh_ = nullptr;
  const ParticleSet* particles_ = nullptr;
  float max_distance_ = 1;
  float epsilon_ = 1e-4f;
};

}  // namespace penumbra
