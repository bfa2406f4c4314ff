// A brick of a data-parallel frame as the light structures see it (DESIGN.md "Built to scale"): the
// march segments it owns, and how the ranks combine the partial maps their bricks built. A technique
// that combines over bricks (ShadowTechnique::combines_over_bricks) marches only the owned segments —
// each segment, classified at its midpoint, is owned by exactly one brick, so a segment cut by a brick
// face is never counted twice — and then combines its map with the other bricks' (CSSM: the
// per-channel minimum of the first-stop depths; classic shadow map: the transparency of the bricks in
// front, then the minimum of the crossing depths), so that the map holds every brick's casters: an
// occluder in one brick shadows a receiver in another.
#pragma once

#include <span>

#include "penumbra/core/sample_slab.h"

namespace penumbra {

// The ranks' reductions: every brick passes its partial values, every brick gets the combined ones.
// Bricks are in slab order (brick b holds slab b, z increasing).
class BrickReduction {
public:
  virtual ~BrickReduction() = default;
  // Elementwise minimum over the bricks.
  virtual void minimum(std::span<float> values) = 0;
  // Elementwise product of the values of the bricks before this one — in increasing slab order when
  // `increasing_z`, else decreasing (the order a light ray going up or down in z crosses them); 1 for
  // the first brick.
  virtual void exclusive_product(std::span<float> values, bool increasing_z) = 0;
  // Elementwise sum over the bricks (the extinction SAT's per-cell sums, accel/extinction_sat.h).
  virtual void sum(std::span<double> values) = 0;
};

struct ShadowBrick {
  SampleSlab slab;
  BrickReduction* reduction;
};

}  // namespace penumbra
