// Histogram and mean of a volume, in two plain passes (range, then binning); double accumulation keeps
// the mean exact enough for volumes of billions of voxels.
#include "penumbra/data/volume_stats.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "penumbra/core/error.h"

namespace penumbra {

VolumeHistogram compute_histogram(const Volume& volume, int bins) {
  if (bins <= 0) throw Error("histogram needs a positive number of bins, got " + std::to_string(bins));
  VolumeHistogram h;
  h.counts.assign(static_cast<std::size_t>(bins), 0);
  const std::size_t n = volume.voxel_count();
  if (n == 0) return h;

  float lo = std::numeric_limits<float>::max(), hi = std::numeric_limits<float>::lowest();
  double sum = 0;
  volume.for_each_value([&](float v, std::size_t count) {
    if (!std::isfinite(v)) throw Error("a voxel is not finite (cannot build a histogram)");
    lo = std::min(lo, v);
    hi = std::max(hi, v);
    sum += static_cast<double>(v) * static_cast<double>(count);
  });
  h.lo = lo;
  h.hi = hi;
  h.mean = sum / static_cast<double>(n);

  // Bin in double so that integer data with bins == value count maps one value to one bin exactly.
  const double width = static_cast<double>(hi) - static_cast<double>(lo);
  const double scale = width > 0 ? static_cast<double>(bins) / width : 0.0;
  const auto last = static_cast<std::size_t>(bins - 1);
  volume.for_each_value([&](float v, std::size_t count) {
    const double t = (static_cast<double>(v) - lo) * scale;
    h.counts[std::min(static_cast<std::size_t>(t), last)] += count;
  });
  return h;
}

}  // namespace penumbra
