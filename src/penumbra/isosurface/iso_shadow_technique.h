// The interface of shadow techniques for isosurfaces (the counterpart of ShadowTechnique and
// SphereShadowTechnique). Point-based isosurfaces are view-dependent, and so are their shadows (paper
// 002 §4): build() sees the frame's receivers — the points extracted for the eye, plus any plane
// points — and light_fraction() answers for those same points, 1 lit and 0 shadowed.
#pragma once

#include <cstddef>
#include <span>
#include <string_view>

#include "penumbra/isosurface/grid_tree.h"
#include "penumbra/isosurface/iso_point.h"
#include "penumbra/scene/light.h"

namespace penumbra {

struct IsoShadowInputs {
  const GridTree* tree;
  float isovalue;
  std::span<const IsoPoint> receivers;
};

class IsoShadowTechnique {
public:
  virtual ~IsoShadowTechnique() = default;
  virtual void build(const IsoShadowInputs& in, const Light& light) = 0;
  virtual void light_fraction(std::span<const IsoPoint> points, std::span<float> out) const = 0;
  virtual std::size_t memory_bytes() const = 0;
  virtual std::string_view name() const = 0;
};

}  // namespace penumbra
