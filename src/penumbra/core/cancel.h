// Cancelling a frame in flight. The thread that renders opens a CancelScope with a flag another thread
// may set; the parallel loops (parallel.h) then skip the chunks they have not started, and
// check_cancelled() — called by the loops when they end and by the renderer between its stages —
// throws Cancelled. Work is cut at chunk granularity (an image tile, a slab of a volume), so a frame
// returns within a chunk's time of the flag being set.
#pragma once

#include <atomic>
#include <stdexcept>

namespace penumbra {

struct Cancelled : std::runtime_error {
  Cancelled() : std::runtime_error("the frame was cancelled") {}
};

class CancelScope {
public:
  explicit CancelScope(const std::atomic<bool>* flag);  // null: nothing to cancel (keeps an outer scope's flag)
  ~CancelScope();
  CancelScope(const CancelScope&) = delete;
  CancelScope& operator=(const CancelScope&) = delete;

private:
  const std::atomic<bool>* previous_;
};

// The current scope's flag (null outside any scope); the parallel loops hand it to their workers.
const std::atomic<bool>* current_cancel_flag();
// Whether the current scope's flag is set (false outside any scope).
bool cancel_requested();
// Throws Cancelled when the current scope's flag is set.
inline void check_cancelled() {
  if (cancel_requested()) throw Cancelled();
}

}  // namespace penumbra
