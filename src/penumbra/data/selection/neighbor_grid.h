// Which atoms lie within a distance of any of a set of reference atoms: one of the two sets binned in
// a uniform grid of cells at least the distance wide, each atom of the other compared with the atoms
// of the 27 cells around its own. The smaller set is the one walked (a few ions against a million
// atoms bins the million and walks the ions). With a periodic cell the grid covers the cell in
// fractional coordinates and wraps, each neighbouring cell visited with its image shift, so distances
// are minimum-image ones (exact for distances up to the cell's smallest width). Walks run in parallel.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/data/selection/periodic_cell.h"

namespace penumbra {

// near[i] = 1 for every i with test[i] set whose distance to some atom j with reference[j] set is
// ≤ cutoff; others 0. All three vectors have one entry per atom.
std::vector<std::uint8_t> points_near(const std::vector<Vec3>& positions, const std::vector<std::uint8_t>& reference,
                                      const std::vector<std::uint8_t>& test, float cutoff,
                                      const std::optional<PeriodicCell>& cell);

}  // namespace penumbra
