// Sphere footprints binned into square tiles of a raster (the screen, or a shadow map), so that each
// tile can then be filled by one thread with a small depth buffer that stays in cache — no atomics,
// and the nearest-hit result does not depend on the order of the bins. Used by the sphere splatting
// (sphere_hits.cpp) and the ISSM generation (implicit_sphere_shadow_map.cpp).
#pragma once

#include <algorithm>
#include <bit>
#include <cstdint>
#include <functional>
#include <iterator>
#include <limits>
#include <span>
#include <utility>
#include <vector>

#include "penumbra/core/math.h"

namespace penumbra {

constexpr int kRasterTile = 32;  // tile edge in pixels / texels

// Inclusive pixel rectangle; empty when x1 < x0 or y1 < y0.
struct PixelRect {
  int x0 = 0, y0 = 0, x1 = -1, y1 = -1;
  bool empty() const { return x1 < x0 || y1 < y0; }
};

// The inclusive range of pixel indices whose centres (i + 0.5) lie in [lo, hi] — widened by one pixel
// on each side, so that a conservative footprint stays conservative — clamped to [0, n − 1]. The
// values are clamped before the integer floor, so far-off footprints do not overflow.
inline void pixel_span(float lo, float hi, int n, int& i0, int& i1) {
  const float fn = static_cast<float>(n);
  i0 = std::max(0, floor_int(std::min(std::max(lo - 0.5f, -2.0f), fn + 1)));
  i1 = std::min(n - 1, floor_int(std::min(std::max(hi - 0.5f, -2.0f), fn + 1)) + 1);
}

// The inclusive range of pixel indices whose centres (i + 0.5) lie in [lo − spare, hi + spare] — a
// footprint known exactly, the spare covering the rounding of the tests that decide a hit there —
// clamped to [0, n − 1]; i1 < i0 when no centre does.
inline void centre_range(float lo, float hi, float spare, int n, int& i0, int& i1) {
  const float fn = static_cast<float>(n);
  i0 = std::max(0, -floor_int(-std::min(std::max(lo - 0.5f - spare, -2.0f), fn + 1)));
  i1 = std::min(n - 1, floor_int(std::min(std::max(hi - 0.5f + spare, -2.0f), fn + 1)));
}

// The same for a disc's exact footprint [c − r, c + r] under a parallel projection, where the hit
// test is the same arithmetic: a hundredth of a pixel to spare.
inline void centre_span(float c, float r, int n, int& i0, int& i1) { centre_range(c - r, c + r, 0.01f, n, i0, i1); }

// The float just above x ≥ 0 (infinity stays): the `tmax` of a hit() that must still return a tie
// with the nearest distance so far, rather than lose it to the strict `t < tmax` of a ray query.
inline float just_above(float x) {
  return x < std::numeric_limits<float>::infinity() ? std::bit_cast<float>(std::bit_cast<std::uint32_t>(x) + 1u) : x;
}

// A lower bound `d` for TileBins::nearest_per_pixel's `nearest`, lowered by a relative margin so that
// it stays below the float-rounded distances it bounds (`scale`: the magnitude of those distances).
inline float lower_bound_with_margin(float d, float scale) { return d - 1e-4f * scale; }

class TileBins {
public:
  // Bins item i into every tile its rectangle touches (empty rectangles are left out).
  TileBins(std::span<const PixelRect> rects, int width, int height);

  // Calls fill(x0, y0, x1, y1, items) for every tile with items, in parallel over tiles; the tile
  // covers the inclusive pixel rectangle [x0, x1] × [y0, y1].
  void for_each_tile(const std::function<void(int, int, int, int, std::span<const std::uint32_t>)>& fill) const;

  // The nearest item per pixel: for every tile with items, begin_tile(x0, y0, x1, y1) makes the tile's
  // state (e.g. its pixels' ray directions), every pixel of every item's rectangle calls
  // hit(state, id, x, y, nearest_so_far) for the item's distance there (infinity: missed, or farther
  // than nearest_so_far — a distance equal to it is a tie and must be returned), and the
  // tile's pixels are then handed to store(x, y, t, id) (t infinity, id kNone where nothing was hit).
  // `id` is always the item's index in `rects`; ties go to the item with the lower `ids_of[id]` (the
  // lower index when `ids_of` is empty: the items are then their own ids), so the
  // result is the same for any thread count, bin order and order of the items.
  //
  // Hidden items are skipped: `nearest[id]` (empty: none known) is a lower bound of every distance
  // hit() can return for the item. A tile takes its items nearest first (in 64 depth buckets); a pixel
  // whose depth is already below an item's bound does not call hit(), and once a bucket's bounds all
  // exceed the farthest depth of a fully covered tile, the tile is done. Skipped items could only have
  // lost, so the result is the same as without the bounds; dense data (a molecule, a million spheres)
  // then costs about what its visible layer costs rather than its depth complexity.
  static constexpr std::uint32_t kNone = 0xFFFFFFFFu;
  template <class BeginTile, class Hit, class Store>
  void nearest_per_pixel(std::span<const PixelRect> rects, std::span<const float> nearest, std::span<const std::uint32_t> ids_of,
                         BeginTile&& begin_tile, Hit&& hit, Store&& store) const {
    constexpr float kInf = std::numeric_limits<float>::infinity();
    for_each_tile([&](int x0, int y0, int x1, int y1, std::span<const std::uint32_t> items) {
      const auto state = begin_tile(x0, y0, x1, y1);
      float depth[kRasterTile * kRasterTile];
      std::uint32_t ids[kRasterTile * kRasterTile];
      // nothing hit yet; an edge tile's places beyond the raster hold −∞: no item reaches them, and the
      // blocks' farthest depths below pass over them
      for (int y = 0; y < kRasterTile; ++y)
        for (int x = 0; x < kRasterTile; ++x) depth[y * kRasterTile + x] = x <= x1 - x0 && y <= y1 - y0 ? kInf : -kInf;
      std::fill(std::begin(ids), std::end(ids), kNone);
      // the farthest depth of each 8×8 block of the tile, as of the last refresh (depths only shrink, so
      // a stale value is a safe upper bound): an item behind every block it touches is skipped whole
      constexpr int kBlock = 8, kBlocks = kRasterTile / kBlock;
      float block_far[kBlocks * kBlocks];
      std::fill(std::begin(block_far), std::end(block_far), kInf);
      auto lower_id = [&](std::uint32_t a, std::uint32_t b) { return ids_of.empty() ? a < b : ids_of[a] < ids_of[b]; };
      auto take = [&](std::uint32_t id, float bound) {
        const PixelRect& r = rects[id];
        const int rx0 = std::max(r.x0, x0), rx1 = std::min(r.x1, x1), ry0 = std::max(r.y0, y0), ry1 = std::min(r.y1, y1);
        float behind = -kInf;
        for (int by = (ry0 - y0) / kBlock; by <= (ry1 - y0) / kBlock; ++by)
          for (int bx = (rx0 - x0) / kBlock; bx <= (rx1 - x0) / kBlock; ++bx) behind = std::max(behind, block_far[by * kBlocks + bx]);
        if (bound > behind) return;
        for (int y = ry0; y <= ry1; ++y)
          for (int x = rx0; x <= rx1; ++x) {
            const int k = (y - y0) * kRasterTile + (x - x0);
            if (bound > depth[k]) continue;
            const float t = hit(state, id, x, y, depth[k]);
            if (t < depth[k] || (t == depth[k] && t != kInf && lower_id(id, ids[k]))) {
              depth[k] = t;
              ids[k] = id;
            }
          }
      };
      if (nearest.empty()) {
        for (const std::uint32_t id : items) take(id, -kInf);
      } else {
        // nearest first, by a counting sort into depth buckets (the order inside a bucket does not
        // matter: a bucket is skipped whole only when its lowest bound lies beyond the tile)
        float lo = kInf, hi = -kInf;
        for (const std::uint32_t id : items) {
          lo = std::min(lo, nearest[id]);
          hi = std::max(hi, nearest[id]);
        }
        constexpr int kBuckets = 64;
        const float scale = hi > lo ? static_cast<float>(kBuckets) / (hi - lo) : 0.0f;
        auto bucket_of = [&](std::uint32_t id) { return std::min(kBuckets - 1, static_cast<int>((nearest[id] - lo) * scale)); };
        std::uint32_t start[kBuckets + 1] = {};
        for (const std::uint32_t id : items) ++start[bucket_of(id) + 1];
        for (int b = 0; b < kBuckets; ++b) start[b + 1] += start[b];
        thread_local std::vector<std::uint32_t> order;  // one buffer per thread, not one per tile
        order.resize(items.size());
        std::uint32_t fill[kBuckets];
        std::copy(start, start + kBuckets, fill);
        for (const std::uint32_t id : items) order[fill[bucket_of(id)]++] = id;
        for (int b = 0; b < kBuckets; ++b) {
          if (start[b] == start[b + 1]) continue;
          // every bound in bucket b is at least lo + b / scale, up to rounding: test the smallest
          float smallest = kInf;
          for (std::uint32_t n = start[b]; n < start[b + 1]; ++n) smallest = std::min(smallest, nearest[order[n]]);
          // per block row the farthest depth of each column (whole rows, which the compiler vectorises),
          // then of each block's eight columns
          float farthest = -kInf;
          for (int by = 0; by < kBlocks; ++by) {
            float column_far[kRasterTile];
            std::copy(depth + by * kBlock * kRasterTile, depth + (by * kBlock + 1) * kRasterTile, column_far);
            for (int y = by * kBlock + 1; y < (by + 1) * kBlock; ++y)
              for (int x = 0; x < kRasterTile; ++x) column_far[x] = column_far[x] < depth[y * kRasterTile + x] ? depth[y * kRasterTile + x] : column_far[x];
            for (int bx = 0; bx < kBlocks; ++bx) {
              float f = column_far[bx * kBlock];
              for (int x = bx * kBlock + 1; x < (bx + 1) * kBlock; ++x) f = f < column_far[x] ? column_far[x] : f;
              block_far[by * kBlocks + bx] = f;
              farthest = farthest < f ? f : farthest;
            }
          }
          if (smallest > farthest) break;  // this bucket and every later one lie behind the tile
          for (std::uint32_t n = start[b]; n < start[b + 1]; ++n) take(order[n], nearest[order[n]]);
        }
      }
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) {
          const int k = (y - y0) * kRasterTile + (x - x0);
          store(x, y, depth[k], ids[k]);
        }
    });
  }

private:
  int width_, height_, tiles_x_, tiles_y_;
  std::vector<std::size_t> offset_;  // tile t holds items_[offset_[t], offset_[t + 1])
  std::vector<std::uint32_t> items_;
};

}  // namespace penumbra
