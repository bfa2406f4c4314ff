// A brick of a data-parallel frame as the light structures see it (DESIGN.md "Built to scale"): the
// march segments it owns, and how the ranks combine the partial maps their bricks built. A technique
// that combines over bricks (ShadowTechnique::combines_over_bricks) marches only the owned segments —
// each segment, classified at its midpoint, is owned by exactly one brick, so a segment cut by a brick
// face is never counted twice — and then combines its map with the other bricks' (CSSM: the
// per-channel minimum of the first-stop depths; classic shadow map: the transparency of the bricks in
// front, then the minimum of the crossing depths), so that the map holds every brick's casters: an
// occluder in one brick shadows a receiver in another.
//
// A particle scene is split by space instead (distributed/distributed_frame.h): each brick holds its
// share of the spheres (ShadowBrick::own_spheres), the implicit sphere shadow map keeps per texel the
// nearest of the bricks' candidates (by depth, carrying the sphere's centre and radius, not an id
// another brick cannot read), and the particle ambient occlusion adds the bricks' splatted densities.
#pragma once

#include <span>

#include "penumbra/core/math.h"
#include "penumbra/core/sample_slab.h"
#include "penumbra/data/particles.h"

namespace penumbra {

// One texel's candidate of a sphere map: the sphere its ray meets first and where (infinity: none).
// Candidates order by depth, then by the sphere's centre and radius, so that every brick picks the same.
struct SphereCandidate {
  float depth = kInfinity;
  Sphere sphere{};
  bool before(const SphereCandidate& o) const {
    if (depth != o.depth) return depth < o.depth;
    const float a[] = {sphere.center.x, sphere.center.y, sphere.center.z, sphere.radius};
    const float b[] = {o.sphere.center.x, o.sphere.center.y, o.sphere.center.z, o.sphere.radius};
    for (int i = 0; i < 4; ++i)
      if (a[i] != b[i]) return a[i] < b[i];
    return false;
  }
};
static_assert(sizeof(SphereCandidate) == 5 * sizeof(float), "SphereCandidate is sent as five floats");

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
  // Elementwise the first candidate over the bricks (SphereCandidate::before).
  virtual void nearest(std::span<SphereCandidate> values) = 0;
};

struct ShadowBrick {
  SampleSlab slab;
  BrickReduction* reduction;
  // The brick holds only its share of the spheres (a particle scene split by space); false: every
  // brick holds all of them, and the sphere structures need no combining.
  bool own_spheres = false;
};

// The box holding every brick's `box` (empty boxes add nothing).
inline Box3 combined_bounds(const Box3& box, BrickReduction& reduction) {
  float v[] = {box.lo.x, box.lo.y, box.lo.z, -box.hi.x, -box.hi.y, -box.hi.z};
  reduction.minimum(v);
  return Box3{{v[0], v[1], v[2]}, {-v[3], -v[4], -v[5]}};
}

}  // namespace penumbra
