#include "penumbra/particles/tile_bins.h"

#include <algorithm>
#include <atomic>

#include "penumbra/core/parallel.h"

namespace penumbra {

TileBins::TileBins(std::span<const PixelRect> rects, int width, int height)
    : width_(width), height_(height), tiles_x_((width + kRasterTile - 1) / kRasterTile),
      tiles_y_((height + kRasterTile - 1) / kRasterTile) {
  const auto tile_count = static_cast<std::size_t>(tiles_x_) * static_cast<std::size_t>(tiles_y_);
  auto for_each_tile_of = [&](const PixelRect& r, auto&& body) {
    for (int ty = r.y0 / kRasterTile; ty <= r.y1 / kRasterTile; ++ty)
      for (int tx = r.x0 / kRasterTile; tx <= r.x1 / kRasterTile; ++tx)
        body(static_cast<std::size_t>(ty) * static_cast<std::size_t>(tiles_x_) + static_cast<std::size_t>(tx));
  };
  // count, prefix sum, fill: the order inside a bin does not matter to its users
  std::vector<std::atomic<std::uint32_t>> counts(tile_count);
  for (auto& c : counts) c.store(0, std::memory_order_relaxed);
  parallel_for(rects.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i)
      if (!rects[i].empty()) for_each_tile_of(rects[i], [&](std::size_t t) { counts[t].fetch_add(1, std::memory_order_relaxed); });
  }, 4096);
  offset_.assign(tile_count + 1, 0);
  for (std::size_t t = 0; t < tile_count; ++t) offset_[t + 1] = offset_[t] + counts[t].load(std::memory_order_relaxed);
  items_.resize(offset_[tile_count]);
  for (auto& c : counts) c.store(0, std::memory_order_relaxed);
  parallel_for(rects.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i)
      if (!rects[i].empty())
        for_each_tile_of(rects[i], [&](std::size_t t) {
          items_[offset_[t] + counts[t].fetch_add(1, std::memory_order_relaxed)] = static_cast<std::uint32_t>(i);
        });
  }, 4096);
}

void TileBins::for_each_tile(const std::function<void(int, int, int, int, std::span<const std::uint32_t>)>& fill) const {
  const std::size_t tile_count = offset_.size() - 1;
  parallel_for(tile_count, [&](std::size_t t0, std::size_t t1) {
    for (std::size_t t = t0; t < t1; ++t) {
      if (offset_[t] == offset_[t + 1]) continue;
      const int x0 = static_cast<int>(t % static_cast<std::size_t>(tiles_x_)) * kRasterTile;
      const int y0 = static_cast<int>(t / static_cast<std::size_t>(tiles_x_)) * kRasterTile;
      fill(x0, y0, std::min(x0 + kRasterTile, width_) - 1, std::min(y0 + kRasterTile, height_) - 1,
           std::span<const std::uint32_t>(items_.data() + offset_[t], offset_[t + 1] - offset_[t]));
    }
  });
}

}  // namespace penumbra
