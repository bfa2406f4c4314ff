// Parallel loops over image tiles and index ranges (oneTBB). Work is split by position, never by
// thread, and every result is written to its own slot, so the output is the same for any thread count.
// Both loops can be cancelled (cancel.h): once the flag is set they start no more chunks and throw
// Cancelled when they end.
#pragma once

#include <cstddef>
#include <functional>
#include <memory>

namespace penumbra {

struct Tile {
  int x0, y0, x1, y1;  // half-open pixel rectangle [x0, x1) x [y0, y1)
};

// Calls body(tile) for every tile of a width x height image, in parallel.
void parallel_for_tiles(int width, int height, int tile_size, const std::function<void(const Tile&)>& body);

// Calls body(begin, end) over chunks of [0, count), in parallel.
void parallel_for(std::size_t count, const std::function<void(std::size_t, std::size_t)>& body,
                  std::size_t grain = 1);

// Limits oneTBB to `threads` worker threads while it lives (0 = all cores).
class ThreadLimit {
public:
  explicit ThreadLimit(int threads);
  ~ThreadLimit();
  ThreadLimit(const ThreadLimit&) = delete;
  ThreadLimit& operator=(const ThreadLimit&) = delete;
  static int current_max();

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace penumbra
