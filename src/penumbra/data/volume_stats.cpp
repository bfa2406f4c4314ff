// Histogram and mean of a volume, in two plain passes (range, then binning); double accumulation keeps
// the mean exact enough for volumes of billions of voxels.
#include "penumbra/data/volume_stats.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "penumbra/core/error.h"

namespace penumbra {
namespace {

// Counts values into h's bins over [h.lo, h.hi], in double so that integer data with bins == value count
// maps one value to one bin exactly.
struct Binning {
  VolumeHistogram& h;
  double lo, scale;
  std::size_t last;
  explicit Binning(VolumeHistogram& histogram)
      : h(histogram), lo(histogram.lo),
        scale(histogram.hi > histogram.lo ? static_cast<double>(histogram.counts.size()) / (static_cast<double>(histogram.hi) - lo) : 0.0),
        last(histogram.counts.size() - 1) {}
  void operator()(float v, std::size_t count) const {
    const double t = (static_cast<double>(v) - lo) * scale;
    h.counts[std::min(static_cast<std::size_t>(t), last)] += count;
  }
};

}  // namespace

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

  volume.for_each_value(Binning(h));
  return h;
}

VolumeHistogram compute_histogram_part(const Volume& volume, int bins, float lo, float hi, int z_first, int z_end) {
  if (bins <= 0) throw Error("histogram needs a positive number of bins, got " + std::to_string(bins));
  if (volume.is_bricked() || z_first < 0 || z_end > volume.dims()[2] || z_first > z_end)
    throw Error("slices " + std::to_string(z_first) + " to " + std::to_string(z_end) + " of a volume of " +
                std::to_string(volume.dims()[2]) + " (dense) slices");
  VolumeHistogram h;
  h.counts.assign(static_cast<std::size_t>(bins), 0);
  h.lo = lo;
  h.hi = hi;
  const std::size_t slice = static_cast<std::size_t>(volume.dims()[0]) * static_cast<std::size_t>(volume.dims()[1]);
  const std::size_t begin = static_cast<std::size_t>(z_first) * slice, end = static_cast<std::size_t>(z_end) * slice;
  const Binning bin(h);
  double sum = 0;
  for (std::size_t i = begin; i < end; ++i) {
    const float v = volume.value(i);
    bin(std::clamp(v, lo, hi), 1);
    sum += static_cast<double>(v);
  }
  h.mean = end > begin ? sum / static_cast<double>(end - begin) : 0.0;
  return h;
}

Box3 box_above(const Volume& volume, float threshold, double trim) {
  if (volume.is_window()) return volume.bounds();
  const auto& d = volume.dims();
  // voxels above the threshold per index along each axis
  std::array<std::vector<std::uint64_t>, 3> counts{std::vector<std::uint64_t>(d[0]), std::vector<std::uint64_t>(d[1]),
                                                  std::vector<std::uint64_t>(d[2])};
  std::uint64_t total = 0;
  for (int k = 0; k < d[2]; ++k)
    for (int j = 0; j < d[1]; ++j)
      for (int i = 0; i < d[0]; ++i)
        if (volume.value(i, j, k) > threshold) {
          ++counts[0][i];
          ++counts[1][j];
          ++counts[2][k];
          ++total;
        }
  Box3 box;
  if (total == 0) return box;
  const auto cut = static_cast<std::uint64_t>(trim * static_cast<double>(total));
  std::array<int, 3> lo{}, hi{};
  for (int a = 0; a < 3; ++a) {
    std::uint64_t seen = 0;
    lo[a] = 0;
    while ((seen += counts[a][lo[a]]) <= cut) ++lo[a];
    seen = 0;
    hi[a] = d[a] - 1;
    while ((seen += counts[a][hi[a]]) <= cut) --hi[a];
  }
  const Vec3& o = volume.origin();
  const Vec3& s = volume.spacing();
  box.extend(o + Vec3{static_cast<float>(lo[0]) * s.x, static_cast<float>(lo[1]) * s.y, static_cast<float>(lo[2]) * s.z});
  box.extend(o + Vec3{static_cast<float>(hi[0]) * s.x, static_cast<float>(hi[1]) * s.y, static_cast<float>(hi[2]) * s.z});
  return box;
}

}  // namespace penumbra
