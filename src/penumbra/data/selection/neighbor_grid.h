// Which points lie within a distance of any of a set of reference points: the references binned in a
// uniform grid of cells at least the distance wide, each point compared with the references of the
// 27 cells around its own. With a periodic cell the grid covers the cell in fractional coordinates and
// wraps, each neighbouring cell visited with its image shift, so distances are minimum-image ones
// (exact for distances up to the cell's smallest width). Points are tested in parallel.
#pragma once

#include <cstdint>
#include <optional>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/data/selection/periodic_cell.h"

namespace penumbra {

// near[i] = 1 for every i with test[i] set whose distance to some reference is ≤ cutoff; others 0.
std::vector<std::uint8_t> points_near(const std::vector<Vec3>& references, const std::vector<Vec3>& points,
                                      const std::vector<std::uint8_t>& test, float cutoff,
                                      const std::optional<PeriodicCell>& cell);

}  // namespace penumbra
