#include "penumbra/geometry/sphere_order.h"

#include <algorithm>
#include <cmath>

#include "penumbra/core/parallel.h"

namespace penumbra {
namespace {

// The ten low bits of v spread to every third bit (bit i to bit 3i).
std::uint32_t spread_bits(std::uint32_t v) {
  v &= 0x3FFu;
  v = (v | (v << 16)) & 0x030000FFu;
  v = (v | (v << 8)) & 0x0300F00Fu;
  v = (v | (v << 4)) & 0x030C30C3u;
  v = (v | (v << 2)) & 0x09249249u;
  return v;
}

}  // namespace

SphereOrder spatial_order(const ParticleSet& set) {
  const std::size_t n = set.size();
  Vec3 lo{kInfinity, kInfinity, kInfinity}, hi{-kInfinity, -kInfinity, -kInfinity};
  double step = 0;  // the summed distance from each centre to the next
  for (std::size_t i = 0; i < n; ++i) {
    lo = min(lo, set.spheres[i].center);
    hi = max(hi, set.spheres[i].center);
    if (i + 1 < n) step += length(set.spheres[i + 1].center - set.spheres[i].center);
  }
  // Already in a spatial order (a molecule's atoms bonded one after the other, a grid written row by
  // row): the next centre lies within a few spacings of the box's n centres, so keep it — a Z-order
  // would cost a sort and gain nothing.
  const Vec3 extent = max(hi - lo, Vec3{});
  const double volume = std::max(static_cast<double>(extent.x) * extent.y * extent.z, 1e-30);
  const double spacing = std::cbrt(volume / static_cast<double>(std::max<std::size_t>(n, 1)));
  if (n < 2 || !std::isfinite(step) || step / static_cast<double>(n - 1) <= kCoherentSteps * spacing) return identity_order(set);
  // the lattice's cell per axis (a flat axis maps to cell 0); non-finite centres go to cell 0 too
  Vec3 scale{};
  for (int a = 0; a < 3; ++a) scale[a] = hi[a] > lo[a] ? 1023.999f / (hi[a] - lo[a]) : 0.0f;
  auto cell = [&](float x, int a) {
    const float c = (x - lo[a]) * scale[a];
    return c >= 0 && c <= 1023.0f ? static_cast<std::uint32_t>(c) : (c > 1023.0f ? 1023u : 0u);
  };
  // (code, index) pairs, sorted by the code's 20 high bits (the Z-order of 2^20 cells: a finer one
  // sorted slower and splatted no faster) with a stable least-significant-digit radix sort of two 10-bit digits, so
  // that spheres in one cell keep their order in the set. Both digits are counted in one pass; the
  // passes run on one thread (split over two, they were slower: they share the memory bandwidth).
  std::vector<std::uint64_t> keys(n), sorted(n);
  parallel_for(n, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      const Vec3& c = set.spheres[i].center;
      const std::uint32_t code = spread_bits(cell(c.x, 0)) | (spread_bits(cell(c.y, 1)) << 1) | (spread_bits(cell(c.z, 2)) << 2);
      keys[i] = (static_cast<std::uint64_t>(code >> 10) << 32) | i;
    }
  }, 1 << 14);
  constexpr std::size_t kDigits = 1024;
  std::vector<std::size_t> start(2 * kDigits, 0);
  for (const std::uint64_t k : keys) {
    ++start[(k >> 32) & 1023u];
    ++start[kDigits + ((k >> 42) & 1023u)];
  }
  for (int digit = 0; digit < 2; ++digit) {
    std::size_t* next = start.data() + digit * kDigits;
    std::size_t running = 0;
    for (std::size_t d = 0; d < kDigits; ++d) {
      const std::size_t count = next[d];
      next[d] = running;
      running += count;
    }
    const int shift = 32 + 10 * digit;
    for (const std::uint64_t k : keys) sorted[next[(k >> shift) & 1023u]++] = k;
    keys.swap(sorted);
  }
  SphereOrder order;
  order.ids.resize(n);
  order.spheres.resize(n);
  parallel_for(n, [&](std::size_t b, std::size_t e) {
    for (std::size_t k = b; k < e; ++k) {
      const auto id = static_cast<std::uint32_t>(keys[k]);
      order.ids[k] = id;
      order.spheres[k] = set.spheres[id];
    }
  }, 1 << 14);
  return order;
}

SphereOrder identity_order(const ParticleSet& set) {
  SphereOrder order;
  order.ids.resize(set.size());
  for (std::size_t i = 0; i < set.size(); ++i) order.ids[i] = static_cast<std::uint32_t>(i);
  order.spheres = set.spheres;
  return order;
}

void carry_order(SphereOrder& previous, const ParticleSet& set) {
  parallel_for(previous.size(), [&](std::size_t b, std::size_t e) {
    for (std::size_t k = b; k < e; ++k) previous.spheres[k] = set.spheres[previous.ids[k]];
  }, 1 << 14);
}

SphereOrder prefix_order(const SphereOrder& order, std::size_t count) {
  SphereOrder prefix;
  prefix.ids.reserve(count);
  prefix.spheres.reserve(count);
  for (std::size_t k = 0; k < order.size(); ++k)
    if (order.ids[k] < count) {
      prefix.ids.push_back(order.ids[k]);
      prefix.spheres.push_back(order.spheres[k]);
    }
  return prefix;
}

}  // namespace penumbra
