#include "penumbra/particles/tile_bins.h"

#include <algorithm>

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
  // Count, prefix sum, fill, per chunk of items: each chunk counts its own items per tile and then
  // writes them at its own offsets, so no counter is shared between threads (atomic counters made the
  // two passes contend on every tile) and a tile holds its items in increasing order for any thread count.
  const std::size_t n = rects.size();
  const std::size_t chunks = std::clamp<std::size_t>(n / 8192, 1, 64), per_chunk = (n + chunks - 1) / chunks;
  std::vector<std::size_t> at(chunks * tile_count, 0);  // chunk c's count, then its next slot, of tile t: at[c·T + t]
  auto chunk_items = [&](auto&& body) {
    parallel_for(chunks, [&](std::size_t c0, std::size_t c1) {
      for (std::size_t c = c0; c < c1; ++c) {
        std::size_t* slot = at.data() + c * tile_count;
        for (std::size_t i = c * per_chunk; i < std::min(n, (c + 1) * per_chunk); ++i)
          if (!rects[i].empty()) for_each_tile_of(rects[i], [&](std::size_t t) { body(slot[t], i); });
      }
    }, 1);
  };
  chunk_items([](std::size_t& count, std::size_t) { ++count; });
  offset_.assign(tile_count + 1, 0);
  std::size_t running = 0;
  for (std::size_t t = 0; t < tile_count; ++t) {
    for (std::size_t c = 0; c < chunks; ++c) {
      const std::size_t count = at[c * tile_count + t];
      at[c * tile_count + t] = running;
      running += count;
    }
    offset_[t + 1] = running;
  }
  items_.resize(running);
  chunk_items([&](std::size_t& next, std::size_t i) { items_[next++] = static_cast<std::uint32_t>(i); });
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
