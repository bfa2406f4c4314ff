// Helpers for the trajectory reader tests (test_trajectory_io.cpp, test_trajectory_mmcif.cpp).
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/math.h"
#include "penumbra/data/io/trajectory_io.h"

namespace penumbra::test {

// The largest coordinate difference between two frames' positions (their sizes must agree).
inline float max_diff(const std::vector<Vec3>& a, const std::vector<Vec3>& b) {
  EXPECT_EQ(a.size(), b.size());
  float m = 0;
  for (std::size_t i = 0; i < std::min(a.size(), b.size()); ++i)
    for (int d = 0; d < 3; ++d) m = std::max(m, std::abs(a[i][d] - b[i][d]));
  return m;
}

// The Error message of opening `path` and reading every frame ("" when none is thrown).
inline std::string error_of(const std::string& path, std::size_t expected_atoms = 0) {
  try {
    auto r = open_trajectory(path, expected_atoms);
    TrajectoryFrame f;
    for (std::size_t k = 0; k < r->frame_count(); ++k) r->read_frame(k, f);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace penumbra::test

// The message `msg` is an Error's (not empty) and names `path` and every further argument.
#define EXPECT_ERROR_NAMES(msg, path, ...)                                                                                      \
  do {                                                                                                                          \
    const std::string m_ = (msg);                                                                                               \
    EXPECT_NE(m_, "") << "no Error for " << (path);                                                                             \
    EXPECT_NE(m_.find(path), std::string::npos) << m_;                                                                          \
    for (const char* part : std::initializer_list<const char*>{__VA_ARGS__}) EXPECT_NE(m_.find(part), std::string::npos) << m_; \
  } while (0)
