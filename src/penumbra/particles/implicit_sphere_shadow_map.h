// Implicit Sphere Shadow Map (Krone et al. 2016, paper 003). Generation (§3): the spheres are rendered
// from the light into an N x N map that keeps, per texel, the sphere nearest to the light along the
// texel's light ray (exact ray–sphere intersection at the texel centre); the map stores the sphere's id
// and a copy of its centre and radius, so that a lookup reads neighbouring texels only, never spheres
// scattered over the particle set (a cache miss each for a million spheres). Lookup (§3.1): the
// receiver is projected into the map and its shadow ray is intersected with the spheres of the (2t+1)²
// texels around it; the receiver's own sphere is skipped (no self-shadowing by identity, §3.2 end).
// Soft shadows (§3.2): occluders are grown by a virtual radius s·w(k), where k is the distance from the
// receiver to the occluder along the shadow ray and w(k) = 1 − exp(−4.5 (k/b)²) a Gaussian weight that
// reaches 99 % at k = b; a ray passing at distance s' from an occluder's surface is darkened by
// (1 − s'/(s·w))^x and the receiver keeps the minimum light over its occluders. Directional lights use
// an orthographic map (the paper); point and spot lights a perspective one fitted to the spheres (the
// paper's future work).
//
// A particle scene split by space over MPI ranks (accel/brick_reduction.h) builds one map per rank from
// its share of the spheres, fitted to the box of all of them, and keeps per texel the nearest of the
// ranks' candidates (depth, centre and radius: one allreduce of 20 bytes a texel); a texel whose sphere
// another rank holds is marked so (kOtherBrickSphere), never mistaken for a receiver's own sphere.
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

#include "penumbra/lighting/shadow_technique.h"
#include "penumbra/lighting/technique_info.h"
#include "penumbra/scene/light_projection.h"

namespace penumbra {

const TechniqueInfo& issm_technique();

// The scene file's shadows.resolution, rings, soft_radius, soft_exponent and soft_distance (declared,
// with their defaults, in issm_technique()).
struct IssmParams {
  int resolution;       // N
  int rings;            // t: texel rings around the receiver's texel
  float soft_radius;    // s: virtual radius growth in world units (0: hard shadows)
  float soft_exponent;  // x
  float soft_distance;  // b: occluder distance (world units) of full softness
};

// Takes spheres only (the catalogue); any point can receive: a volume sample or a point on a plane or
// an isosurface is shadowed by the spheres it looks past, a point on a sphere by every other sphere.
class ImplicitSphereShadowMap final : public ShadowTechnique {
public:
  using ShadowTechnique::transmittance;
  // params.rings < 0: automatic (§4), chosen every frame for its receivers.
  explicit ImplicitSphereShadowMap(const IssmParams& params) : params_(params), automatic_rings_(params.rings < 0) {
    if (automatic_rings_) params_.rings = 0;
  }
  // A texel holding a sphere of another brick (its centre and radius are in the map; its id is not ours).
  static constexpr std::uint32_t kOtherBrickSphere = kNoSphere - 1;

  void build(const ShadowCasters& casters, const Light& light) override;
  // Built from one brick's spheres, combined with the other bricks' (a particle scene split by space).
  bool combines_over_bricks() const override { return true; }
  void fit_to_receivers(std::span<const SurfacePoint> receivers, bool volume_samples, bool refined) override;
  void transmittance(std::span<const Vec3> points, std::span<Rgb> out) const override;
  void transmittance(std::span<const SurfacePoint> points, std::span<Rgb> out) const override;
  Vec3 surface_receiver(const Vec3& p, const Vec3&) const override { return p; }  // self by identity
  void add_stats(ShadowStats& stats) const override { stats.issm_rings = rings(); }
  std::size_t memory_bytes() const override {
    return map_.capacity() * sizeof(std::uint32_t) + map_spheres_.capacity() * sizeof(Sphere);
  }
  std::string_view name() const override { return "issm"; }

  // The automatic choice of t (§4) re-queries the same map with more rings.
  void set_rings(int rings) { params_.rings = rings; }
  // The rings used: the asked t, raised for soft shadows to ⌈s / texel⌉ so that the patch reaches
  // every occluder whose grown radius can cross the shadow ray (§3.2: "t must be chosen large enough").
  int rings() const { return std::max(params_.rings, soft_rings_); }
  // The sphere stored in texel (i, j), kNoSphere where the light reaches the far side,
  // kOtherBrickSphere for another brick's (for figures).
  std::uint32_t texel(int i, int j) const { return map_[static_cast<std::size_t>(j) * static_cast<std::size_t>(params_.resolution) + static_cast<std::size_t>(i)]; }
  int resolution() const { return params_.resolution; }

  // The automatic choice of t (paper 003 §4): t grows from 0 until the light fractions of `points`
  // stop changing — at most `max_changed` of them change by more than 1/255 — or t reaches max_rings.
  // Leaves the map at the chosen t and returns it.
  int choose_rings(std::span<const SurfacePoint> points, int max_rings = 8, double max_changed = 1e-4);

private:
  // The spheres are split over bricks: each texel keeps the first of the bricks' candidates (this
  // brick's texel depths in depth_of, infinity where it has none).
  void keep_nearest_over_bricks(std::span<const float> depth_of);
  // `self`: the receiver's sphere, kNoSphere for points on anything else.
  float light_at(const Vec3& p, std::uint32_t self) const;

  IssmParams params_;
  bool automatic_rings_;
  const ParticleSet* particles_ = nullptr;
  Light light_;
  LightProjection projection_;
  std::vector<std::uint32_t> map_;
  std::vector<Sphere> map_spheres_;  // per texel: the centre and radius of map_'s sphere
  int soft_rings_ = 0;
  BrickReduction* reduction_ = nullptr;  // the spheres are split over bricks: combine through this
};

}  // namespace penumbra
