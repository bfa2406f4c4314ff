// The trajectory readers (XTC, DCD) through open_trajectory: the frame index built at open, then every
// frame read (at most 64, in order and then one backwards), each either a frame or a penumbra::Error.
#pragma once

#include <algorithm>

#include "fuzz_common.h"
#include "penumbra/data/io/trajectory_io.h"

namespace penumbra::fuzz {

inline int fuzz_trajectory(const char* name, const std::uint8_t* data, std::size_t size) {
  const std::string path = write_input(name, data, size);
  expect_error_or_result([&] {
    auto r = open_trajectory(path);
    TrajectoryFrame f;
    const std::size_t n = std::min<std::size_t>(r->frame_count(), 64);
    for (std::size_t k = 0; k < n; ++k) r->read_frame(k, f);
    if (n > 1) r->read_frame(0, f);
    (void)r->memory_bytes();
  });
  return 0;
}

}  // namespace penumbra::fuzz
