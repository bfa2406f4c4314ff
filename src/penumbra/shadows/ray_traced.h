// The exact reference: for every receiver, march a shadow ray to the light through the volume and
// multiply the colour model's per-segment transmittance 1 − α_i·(1 − t_{i,λ}) (DESIGN.md colour model);
// an opaque plane on the way gives zero. Segments are the lattice [kΔ, (k+1)Δ] from the receiver,
// sampled at their midpoints, the last one opacity-corrected for its length, so a homogeneous medium
// gives exactly (1 − α)^(L/Δ_ref). Nothing is built; every query costs a full ray march.
#pragma once

#include "penumbra/shadows/shadow_technique.h"

namespace penumbra {

class RayTracedShadows final : public ShadowTechnique {
public:
  using ShadowTechnique::transmittance;  // keep the one-point overload visible
  void build(const ShadowMedium& medium, const Light& light) override {
    medium_ = &medium;
    light_ = light;
    const Box3& b = medium.bounds();
    epsilon_ = 1e-4f * (b.empty() ? 1.0f : std::max(b.radius(), 1e-6f));
  }
  void transmittance(std::span<const Vec3> points, std::span<Rgb> out) const override {
    for (std::size_t i = 0; i < points.size(); ++i) {
      Vec3 to_light;
      float distance;
      light_.towards(points[i], to_light, distance);
      out[i] = medium_->transmittance(Ray{points[i], to_light}, 0, distance);
    }
  }
  Vec3 surface_receiver(const Vec3& p, const Vec3& n) const override {
    return offset_towards_light(light_, p, n, epsilon_);
  }
  std::size_t memory_bytes() const override { return 0; }
  std::string_view name() const override { return "ray_traced"; }

private:
  const ShadowMedium* medium_ = nullptr;
  Light light_;
  float epsilon_ = 1e-4f;
};

// No shadows: every point receives the full light.
class NoShadows final : public ShadowTechnique {
public:
  using ShadowTechnique::transmittance;  // keep the one-point overload visible
  void build(const ShadowMedium&, const Light&) override {}
  void transmittance(std::span<const Vec3>, std::span<Rgb> out) const override {
    for (auto& o : out) o = Rgb(1.0f);
  }
  Vec3 surface_receiver(const Vec3& p, const Vec3&) const override { return p; }
  std::size_t memory_bytes() const override { return 0; }
  std::string_view name() const override { return "none"; }
};

}  // namespace penumbra
