#include "penumbra/core/parallel.h"

#include <tbb/blocked_range.h>
#include <tbb/blocked_range2d.h>
#include <tbb/global_control.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <optional>

#include "penumbra/core/cancel.h"

namespace penumbra {

void parallel_for_tiles(int width, int height, int tile_size, const std::function<void(const Tile&)>& body) {
  const int tiles_x = (width + tile_size - 1) / tile_size;
  const int tiles_y = (height + tile_size - 1) / tile_size;
  const std::atomic<bool>* flag = current_cancel_flag();
  tbb::parallel_for(tbb::blocked_range<int>(0, tiles_x * tiles_y, 1), [&](const tbb::blocked_range<int>& r) {
    const CancelScope scope(flag);  // loops nested in the body see the flag too
    for (int t = r.begin(); t < r.end(); ++t) {
      if (cancel_requested()) return;
      const int tx = t % tiles_x, ty = t / tiles_x;
      Tile tile{tx * tile_size, ty * tile_size, std::min(width, (tx + 1) * tile_size),
                std::min(height, (ty + 1) * tile_size)};
      body(tile);
    }
  });
  check_cancelled();
}

void parallel_for(std::size_t count, const std::function<void(std::size_t, std::size_t)>& body, std::size_t grain) {
  const std::atomic<bool>* flag = current_cancel_flag();
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, count, std::max<std::size_t>(1, grain)),
                    [&](const tbb::blocked_range<std::size_t>& r) {
                      const CancelScope scope(flag);
                      if (!cancel_requested()) body(r.begin(), r.end());
                    });
  check_cancelled();
}

struct ThreadLimit::Impl {
  std::optional<tbb::global_control> control;
};

ThreadLimit::ThreadLimit(int threads) : impl_(std::make_unique<Impl>()) {
  if (threads > 0)
    impl_->control.emplace(tbb::global_control::max_allowed_parallelism, static_cast<std::size_t>(threads));
}
ThreadLimit::~ThreadLimit() = default;

int ThreadLimit::current_max() {
  return static_cast<int>(tbb::global_control::active_value(tbb::global_control::max_allowed_parallelism));
}

}  // namespace penumbra
