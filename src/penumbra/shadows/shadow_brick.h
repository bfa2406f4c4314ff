// A brick of a data-parallel frame as the light structures see it (DESIGN.md "Built to scale"): the
// march segments it owns, and how the ranks combine the partial maps their bricks built. A technique
// that combines over bricks (ShadowTechnique::combines_over_bricks) marches only the owned segments —
// each segment, classified at its midpoint, is owned by exactly one brick, so a segment cut by a brick
// face is never counted twice — and then combines its map with the other bricks' (CSSM: the
// per-channel minimum of the first-stop depths), so that the map holds every brick's casters: an
// occluder in one brick shadows a receiver in another.
#pragma once

#include <span>

#include "penumbra/core/sample_slab.h"

namespace penumbra {

// The ranks' reduction: every brick passes its partial values, every brick gets the combined ones.
class BrickReduction {
public:
  virtual ~BrickReduction() = default;
  virtual void minimum(std::span<float> values) = 0;  // elementwise minimum over the bricks
};

struct ShadowBrick {
  SampleSlab slab;
  BrickReduction* reduction;
};

}  // namespace penumbra
