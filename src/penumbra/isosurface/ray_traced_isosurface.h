// The exact reference for isosurface shadows: one shadow ray per receiver towards the light, shadowed
// when it crosses the isosurface (the first root of the trilinear interpolant, IsosurfaceRaycaster)
// before reaching the light.
#pragma once

#include <memory>

#include "penumbra/isosurface/iso_shadow_technique.h"
#include "penumbra/isosurface/isosurface_raycaster.h"

namespace penumbra {

class RayTracedIsosurfaceShadows final : public IsoShadowTechnique {
public:
  void build(const IsoShadowInputs& in, const Light& light) override;
  void light_fraction(std::span<const IsoPoint> points, std::span<float> out) const override;
  std::size_t memory_bytes() const override { return 0; }
  std::string_view name() const override { return "ray_traced"; }

private:
  std::unique_ptr<IsosurfaceRaycaster> raycaster_;
  Light light_;
  float offset_ = 0;  // shadow rays start this far off the surface, along the normal
};

class NoIsosurfaceShadows final : public IsoShadowTechnique {
public:
  void build(const IsoShadowInputs&, const Light&) override {}
  void light_fraction(std::span<const IsoPoint>, std::span<float> out) const override {
    for (float& f : out) f = 1;
  }
  std::size_t memory_bytes() const override { return 0; }
  std::string_view name() const override { return "none"; }
};

}  // namespace penumbra
