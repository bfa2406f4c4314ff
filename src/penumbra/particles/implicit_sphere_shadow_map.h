// Implicit Sphere Shadow Map (Krone et al. 2016, paper 003). Generation (§3): the spheres are rendered
// from the light into an N x N map that keeps, per texel, the sphere nearest to the light along the
// texel's light ray (exact ray–sphere intersection at the texel centre); the map stores the sphere's id,
// its centre and radius are read from the particle set. Lookup (§3.1): the receiver is projected into
// the map and its shadow ray is intersected with the spheres of the (2t+1)² texels around it; the
// receiver's own sphere is skipped (no self-shadowing by identity, §3.2 end). Soft shadows (§3.2):
// occluders are grown by a virtual radius s·w(k), where k is the distance from the receiver to the
// occluder along the shadow ray and w(k) = 1 − exp(−4.5 (k/b)²) a Gaussian weight that reaches 99 % at
// k = b; a ray passing at distance s' from an occluder's surface is darkened by (1 − s'/(s·w))^x and
// the receiver keeps the minimum light over its occluders. Directional lights use an orthographic map
// (the paper); point and spot lights a perspective one fitted to the spheres (the paper's future work).
//
// | parameter             | default | meaning                                                          |
// | shadows.resolution    | 1024    | N, texels per side (the paper's benchmarks: 512)                  |
// | shadows.rings         | 1       | t, texel rings searched around the receiver's texel; −1 automatic |
// | shadows.soft_radius   | 0       | s, virtual radius growth in world units (0: hard shadows)         |
// | shadows.soft_exponent | 1       | x, the penumbra's falloff (1 − s'/s)^x                            |
// | shadows.soft_distance | 10      | b, occluder distance (world units) of full softness               |
#pragma once

#include <algorithm>
#include <vector>

#include "penumbra/particles/sphere_shadow_technique.h"
#include "penumbra/scene/light_projection.h"

namespace penumbra {

// The scene file's shadows.resolution, rings, soft_radius, soft_exponent and soft_distance (their
// defaults are ShadowSettings').
struct IssmParams {
  int resolution;       // N
  int rings;            // t: texel rings around the receiver's texel
  float soft_radius;    // s: virtual radius growth in world units (0: hard shadows)
  float soft_exponent;  // x
  float soft_distance;  // b: occluder distance (world units) of full softness
};

class ImplicitSphereShadowMap final : public SphereShadowTechnique {
public:
  explicit ImplicitSphereShadowMap(const IssmParams& params) : params_(params) {}
  void build(const ParticleScene& scene, const Light& light) override;
  void light_fraction(std::span<const SurfacePoint> points, std::span<float> out) const override;
  std::size_t memory_bytes() const override { return map_.capacity() * sizeof(std::uint32_t); }
  std::string_view name() const override { return "issm"; }

  // The automatic choice of t (§4) re-queries the same map with more rings.
  void set_rings(int rings) { params_.rings = rings; }
  // The rings used: the asked t, raised for soft shadows to ⌈s / texel⌉ so that the patch reaches
  // every occluder whose grown radius can cross the shadow ray (§3.2: "t must be chosen large enough").
  int rings() const { return std::max(params_.rings, soft_rings_); }
  // The sphere stored in texel (i, j), kNoSphere where the light reaches the far side (for figures).
  std::uint32_t texel(int i, int j) const { return map_[static_cast<std::size_t>(j) * static_cast<std::size_t>(params_.resolution) + static_cast<std::size_t>(i)]; }
  int resolution() const { return params_.resolution; }

private:
  float light_at(const SurfacePoint& p) const;

  IssmParams params_;
  const ParticleSet* particles_ = nullptr;
  Light light_;
  LightProjection projection_;
  std::vector<std::uint32_t> map_;
  int soft_rings_ = 0;
};

}  // namespace penumbra
