// Summary statistics of a volume's voxel values: a histogram over the value range and the mean, used
// to place transfer-function control points and to sanity-check loaded data.
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/data/volume.h"

namespace penumbra {

struct VolumeHistogram {
  float lo = 0, hi = 0;                // smallest and largest voxel value
  std::vector<std::uint64_t> counts;   // bins of equal width spanning [lo, hi]; hi falls in the last bin
  double mean = 0;                     // mean voxel value
};

// Scans the voxels themselves (not the cached range). bins must be positive; non-finite voxels are an
// Error. When all voxels are equal (lo == hi) every voxel is counted in bin 0.
VolumeHistogram compute_histogram(const Volume& volume, int bins);

// The part of a histogram over [lo, hi] (the whole grid's range, found before) that slices [z_first,
// z_end) of a dense volume hold: the parts of the slices a grid is cut into add up, bin by bin, to the
// whole grid's histogram (a distributed volume's, distributed/brick_reading.h). `mean` is theirs alone.
VolumeHistogram compute_histogram_part(const Volume& volume, int bins, float lo, float hi, int z_first, int z_end);

// The world box of the voxel centres whose value exceeds `threshold` (empty when none does), less
// the `trim` share of those voxels at each end of each axis, so that stray voxels (noise, specks) do
// not widen it: where the visible material lies, for framing. A window (one rank's slices) gives its
// whole grid's bounds().
Box3 box_above(const Volume& volume, float threshold, double trim);

}  // namespace penumbra
