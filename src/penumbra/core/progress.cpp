#include "penumbra/core/progress.h"

#include <unistd.h>

#include <cstdio>

namespace penumbra {
namespace {
constexpr double kShowAfterMs = 1500.0;  // "longer than a couple of seconds": start drawing after 1.5 s
std::atomic<int> g_enabled{-1};          // -1: decide by isatty
Progress::Observer g_observer;  // set and cleared while no work runs (set_observer)
std::atomic<bool> g_observed{false};
bool enabled() {
  int e = g_enabled.load();
  if (e < 0) {
    e = isatty(STDERR_FILENO) ? 1 : 0;
    g_enabled.store(e);
  }
  return e == 1;
}
}  // namespace

void Progress::set_enabled(bool on) { g_enabled.store(on ? 1 : 0); }

void Progress::set_observer(Observer observer) {
  g_observed.store(false);
  g_observer = std::move(observer);
  g_observed.store(static_cast<bool>(g_observer));
}

Progress::Progress(std::string label, std::size_t total) : label_(std::move(label)), total_(total) {}

Progress::~Progress() {
  if (shown_.load()) std::fprintf(stderr, "\r%s: done in %.1f s      \n", label_.c_str(), timer_.elapsed_ms() / 1000.0);
}

void Progress::advance(std::size_t n) {
  const std::size_t done = done_.fetch_add(n) + n;
  if (g_observed.load(std::memory_order_acquire)) g_observer(label_, done, total_);
  if (!enabled() || total_ == 0) return;
  if (timer_.elapsed_ms() < kShowAfterMs) return;
  const int percent = static_cast<int>(100.0 * static_cast<double>(done) / static_cast<double>(total_));
  int last = last_percent_.load();
  if (percent > last && last_percent_.compare_exchange_strong(last, percent)) {
    shown_.store(true);
    std::fprintf(stderr, "\r%s: %3d%%", label_.c_str(), percent);
    std::fflush(stderr);
  }
}

}  // namespace penumbra
