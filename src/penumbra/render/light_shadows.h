// Everything that shadows one light: one technique per group of caster kinds (technique_catalog.h,
// shadow_assignments), each built from a ShadowCasters restricted to its kinds. A light's
// transmittance to a point is the product over the group: every caster is covered exactly once.
// Receivers that do not receive shadows (receives_shadows: false) are not asked.
#pragma once

#include <memory>
#include <span>
#include <vector>

#include "penumbra/lighting/shadow_technique.h"

namespace penumbra {

class LightShadows {
public:
  // Builds every group's technique for `light` from `all` (which must outlive this). With a brick, the
  // techniques that combine over bricks build from its segments only and combine with the other
  // bricks' (shadow_brick.h); the others build from `all`, which then holds the whole scene.
  LightShadows(const Scene& scene, const ShadowCasters& all, const Light& light, const ShadowBrick* brick = nullptr);

  void fit_to_receivers(std::span<const SurfacePoint> receivers, bool volume_samples, bool refined);
  void transmittance(std::span<const Vec3> points, std::span<Rgb> out) const;
  void transmittance(std::span<const SurfacePoint> points, std::span<Rgb> out) const;
  Rgb transmittance(const Vec3& p) const {
    Rgb out;
    transmittance(std::span<const Vec3>(&p, 1), std::span<Rgb>(&out, 1));
    return out;
  }

  const std::vector<std::unique_ptr<ShadowTechnique>>& techniques() const { return techniques_; }
  std::size_t memory_bytes() const;
  void add_stats(ShadowStats& stats) const;

private:
  std::vector<std::unique_ptr<ShadowCasters>> casters_;  // one per technique, its kinds only
  std::vector<std::unique_ptr<ShadowTechnique>> techniques_;
};

}  // namespace penumbra
