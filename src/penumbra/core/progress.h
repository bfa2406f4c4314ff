// Progress on stderr for long work, shown only when stderr is a terminal and the work has taken
// longer than a moment. Thread-safe: workers call advance(), one of them redraws.
#pragma once

#include <atomic>
#include <cstddef>
#include <string>

#include "penumbra/core/timer.h"

namespace penumbra {

class Progress {
public:
  Progress(std::string label, std::size_t total);
  ~Progress();
  void advance(std::size_t n = 1);
  static void set_enabled(bool enabled);  // default: enabled when stderr is a terminal

private:
  std::string label_;
  std::size_t total_;
  std::atomic<std::size_t> done_{0};
  std::atomic<int> last_percent_{-1};
  std::atomic<bool> shown_{false};
  Timer timer_;
};

}  // namespace penumbra
