// The passes over files a window at a time (volume_io.h WindowPass) and the parked streams they keep
// (parked_stream.h).
#include <mutex>
#include <vector>

#include "penumbra/data/io/parked_stream.h"
#include "penumbra/data/io/volume_io.h"

namespace penumbra {
namespace {

std::mutex pass_mutex;
int open_passes = 0;

// Held by pointer so that the parked streams of static readers may register before main and outlive it.
std::vector<std::function<void()>>& droppers() {
  static auto* list = new std::vector<std::function<void()>>;
  return *list;
}

}  // namespace

namespace io_detail {

bool window_pass_open() {
  std::lock_guard lock(pass_mutex);
  return open_passes > 0;
}

void on_window_pass_end(std::function<void()> drop) {
  std::lock_guard lock(pass_mutex);
  droppers().push_back(std::move(drop));
}

}  // namespace io_detail

WindowPass::WindowPass() {
  std::lock_guard lock(pass_mutex);
  ++open_passes;
}

WindowPass::~WindowPass() {
  std::vector<std::function<void()>> drop;
  {
    std::lock_guard lock(pass_mutex);
    if (--open_passes > 0) return;
    drop = droppers();
  }
  for (const auto& d : drop) d();
}

}  // namespace penumbra
