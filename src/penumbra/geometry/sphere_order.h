// The spheres of a set in a spatial order: the Z-order (Morton) curve of their centres, with a copy of
// each sphere in that order. The splats that find each pixel's or texel's nearest sphere
// (particles/sphere_hits.cpp, particles/implicit_sphere_shadow_map.cpp) bin and walk the spheres in this order, so that
// the spheres of one 32×32 tile lie near one another in memory: a file's or a generator's order may
// scatter neighbours over the whole set (a cache miss per sphere for a million of them), and a tile's
// bounds, footprints and spheres are then read from a few cache lines instead. The order changes no
// result: the splats break ties by the spheres' ids in the set, never by their place in the order.
//
// Built once per set of spheres (the renderer keeps it with the merged set); 1 M spheres take about
// 20 MB (the copy and the permutation).
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/data/particles.h"

namespace penumbra {

struct SphereOrder {
  std::vector<std::uint32_t> ids;  // ids[k]: the index in the set of the k-th sphere of the order
  std::vector<Sphere> spheres;     // spheres[k] == set.spheres[ids[k]]

  std::size_t size() const { return ids.size(); }
  std::size_t memory_bytes() const { return ids.capacity() * sizeof(std::uint32_t) + spheres.capacity() * sizeof(Sphere); }
};

// The set's own order when it is already spatial — the mean distance from one centre to the next at
// most kCoherentSteps times the spacing of the set's centres spread evenly over their bounding box (a
// molecule's atoms, a grid written row by row) — and otherwise the Z-order of 2^20 cells over that box
// (64 × 128 × 128 of them; about one sphere a cell for a million), in one cell by index in the set.
constexpr double kCoherentSteps = 8;
SphereOrder spatial_order(const ParticleSet& set);
SphereOrder identity_order(const ParticleSet& set);

// `previous`, the order of a set of the same size, carried over to `set` in place (a trajectory's next
// frame: the atoms moved little, so the order stays spatial, and no sort is needed; any order is correct).
void carry_order(SphereOrder& previous, const ParticleSet& set);

// The same order restricted to the spheres with index below `count` (a prefix of the set: the renderer's
// casting spheres), which keeps it a Z-order.
SphereOrder prefix_order(const SphereOrder& order, std::size_t count);

}  // namespace penumbra
