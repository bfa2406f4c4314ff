// The exact reference, for every kind of caster at once: for every receiver, a shadow ray to the light
// through the volumes (the colour model's per-segment transmittance 1 − α_i·(1 − t_{i,λ}), multiplied,
// DESIGN.md), zero when a sphere, an isosurface (the first root of its trilinear interpolant) or a
// plane lies on the way. Segments are the lattice [kΔ, (k+1)Δ] from the receiver, sampled at their
// midpoints, the last one opacity-corrected for its length, so a homogeneous medium gives exactly
// (1 − α)^(L/Δ_ref). A surface point's ray starts just off its own surface (ShadowCasters::ray_origin).
// With light_angle > 0 the light is a round source of that angular radius (for point and spot lights
// a ball subtending it at the casters' centre) and `area_rays` rays spread uniformly over its solid
// angle (a rotated Fibonacci lattice, ray_sampling.h) are averaged: soft shadows. Nothing is built;
// every query costs full ray marches.
//
// | parameter             | default  | meaning                                                    |
// | shadows.step          | 1 voxel  | light-ray sampling step in voxels                           |
// | shadows.light_angle   | 0        | angular radius of the light, degrees (0: a point)           |
// | shadows.area_rays     | 64       | shadow rays per receiver when light_angle > 0               |
#pragma once

#include "penumbra/lighting/shadow_technique.h"
#include "penumbra/lighting/technique_info.h"

namespace penumbra {

const TechniqueInfo& ray_traced_technique();
const TechniqueInfo& no_shadows_technique();  // "none"

class RayTracedShadows final : public ShadowTechnique {
public:
  using ShadowTechnique::transmittance;  // keep the one-point overload visible
  explicit RayTracedShadows(float light_angle_deg = 0, int area_rays = 64) : light_angle_deg_(light_angle_deg), area_rays_(area_rays) {}
  void build(const ShadowCasters& casters, const Light& light) override;
  // A preview's receivers lie on the opened levels' isosurfaces: its rays meet those, not a refined box's.
  void fit_to_receivers(std::span<const SurfacePoint>, bool, bool refined) override { refined_ = refined; }
  void transmittance(std::span<const Vec3> points, std::span<Rgb> out) const override;
  void transmittance(std::span<const SurfacePoint> points, std::span<Rgb> out) const override;
  Vec3 surface_receiver(const Vec3& p, const Vec3& n) const override {
    return offset_towards_light(light_, p, n, casters_->epsilon());
  }
  std::size_t memory_bytes() const override { return 0; }  // a shared BVH is counted by the renderer
  std::string_view name() const override { return "ray_traced"; }

private:
  // The light reaching `origin` (a receiver at `key`, which keys the sample pattern).
  Rgb exact(const Vec3& origin, const Vec3& key) const;

  float light_angle_deg_;
  int area_rays_;
  const ShadowCasters* casters_ = nullptr;
  Light light_;
  float tan_light_radius_ = 0;
  Vec3 centre_;
  bool refined_ = true;  // the frame's receivers were drawn from refined boxes (fit_to_receivers)
};

// No shadows: every point receives the full light.
class NoShadows final : public ShadowTechnique {
public:
  using ShadowTechnique::transmittance;  // keep the one-point overload visible
  void build(const ShadowCasters&, const Light&) override {}
  void transmittance(std::span<const Vec3>, std::span<Rgb> out) const override {
    for (auto& o : out) o = Rgb(1.0f);
  }
  void transmittance(std::span<const SurfacePoint>, std::span<Rgb> out) const override {
    for (auto& o : out) o = Rgb(1.0f);
  }
  Vec3 surface_receiver(const Vec3& p, const Vec3&) const override { return p; }
  std::size_t memory_bytes() const override { return 0; }
  std::string_view name() const override { return "none"; }
};

}  // namespace penumbra
