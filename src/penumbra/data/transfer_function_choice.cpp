#include "penumbra/data/transfer_function_choice.h"

#include <algorithm>
#include <cstdint>
#include <vector>

#include "penumbra/data/volume_stats.h"

namespace penumbra {
namespace {

constexpr double kBackgroundShare = 0.2;

// The value below which `share` of the counted voxels lie (bins [first, last) of the histogram).
double percentile(const VolumeHistogram& h, std::size_t first, std::size_t last, double share) {
  std::uint64_t total = 0;
  for (std::size_t b = first; b < last; ++b) total += h.counts[b];
  const double width = (static_cast<double>(h.hi) - h.lo) / static_cast<double>(h.counts.size());
  const double target = share * static_cast<double>(total);
  double seen = 0;
  for (std::size_t b = first; b < last; ++b) {
    const double next = seen + static_cast<double>(h.counts[b]);
    if (next >= target && h.counts[b] > 0)  // inside this bin, linearly
      return h.lo + width * (static_cast<double>(b) + (target - seen) / static_cast<double>(h.counts[b]));
    seen = next;
  }
  return h.lo + width * static_cast<double>(last);
}

}  // namespace

bool is_hounsfield_ct(ScalarType type, float lo, float hi) {
  const bool signed_type = type == ScalarType::Int16 || type == ScalarType::Float32;
  return signed_type && lo <= -900.0f && hi >= 300.0f;
}

nlohmann::json choose_transfer_function(const Volume& volume) {
  if (is_hounsfield_ct(volume.type(), volume.min_value(), volume.max_value())) return {{"preset", "ct-bone"}};
  if (!(volume.max_value() > volume.min_value())) return {{"preset", "grayscale"}};
  return choose_transfer_function(compute_histogram(volume, kTransferChoiceBins), volume.type());
}

nlohmann::json choose_transfer_function(const VolumeHistogram& h, ScalarType type) {
  if (is_hounsfield_ct(type, h.lo, h.hi)) return {{"preset", "ct-bone"}};
  if (!(h.hi > h.lo)) return {{"preset", "grayscale"}};
  const auto bins = static_cast<double>(h.counts.size());
  const auto mode = static_cast<std::size_t>(std::max_element(h.counts.begin(), h.counts.end()) - h.counts.begin());
  double voxels = 0;
  for (const std::uint64_t c : h.counts) voxels += static_cast<double>(c);
  std::size_t first = 0;
  if (static_cast<double>(h.counts[mode]) >= kBackgroundShare * voxels && mode < h.counts.size() / 2) first = mode + 1;
  double lo = percentile(h, first, h.counts.size(), 0.5);
  double hi = percentile(h, first, h.counts.size(), 0.995);
  if (!(hi > lo)) {  // nearly all foreground voxels in one bin: ramp over that bin to the maximum
    lo = h.lo + (static_cast<double>(h.hi) - h.lo) * static_cast<double>(first) / bins;
    hi = h.hi;
  }
  auto at = [&](double t) { return lo + t * (hi - lo); };
  // [value, r, g, b, alpha], linear RGB
  nlohmann::json points = nlohmann::json::array({
      {lo, 0.25, 0.05, 0.02, 0.0},
      {at(0.25), 0.65, 0.18, 0.06, 0.02},
      {at(0.6), 0.9, 0.55, 0.3, 0.15},
      {hi, 1.0, 0.92, 0.8, 0.6},
  });
  if (h.hi > hi) points.push_back({h.hi, 1.0, 0.95, 0.9, 0.6});
  return {{"points", points}};
}

}  // namespace penumbra
