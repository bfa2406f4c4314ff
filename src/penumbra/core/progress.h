// Progress on stderr for long work, shown only when stderr is a terminal and the work has taken
// longer than a moment. Thread-safe: workers call advance(), one of them redraws. An observer, when
// set, sees every advance as it happens (label, units done, total) on the worker that made it: a
// test sets a frame's cancel flag at a chosen point of its work this way, without a clock.
#pragma once

#include <atomic>
#include <cstddef>
#include <functional>
#include <string>
#include <string_view>

#include "penumbra/core/timer.h"

namespace penumbra {

class Progress {
public:
  Progress(std::string label, std::size_t total);
  ~Progress();
  void advance(std::size_t n = 1);
  static void set_enabled(bool enabled);  // default: enabled when stderr is a terminal
  // Called from any worker thread, so it must be thread-safe; an empty function removes it. Set it while
  // no work is in progress.
  using Observer = std::function<void(std::string_view label, std::size_t done, std::size_t total)>;
  static void set_observer(Observer observer);

private:
  std::string label_;
  std::size_t total_;
  std::atomic<std::size_t> done_{0};
  std::atomic<int> last_percent_{-1};
  std::atomic<bool> shown_{false};
  Timer timer_;
};

}  // namespace penumbra
