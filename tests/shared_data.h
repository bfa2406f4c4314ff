// Where the tests find ../shared/data (PENUMBRA_DATA_DIR overrides the path compiled in), and a skip for
// a test whose staged file is absent, so that the suite runs on a checkout without the data.
#pragma once

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <string>

namespace penumbra::test {

inline const std::string& shared_data_dir() {
  static const std::string dir = [] {
    const char* env = std::getenv("PENUMBRA_DATA_DIR");
    return env && *env ? std::string(env) : std::string(PENUMBRA_SHARED_DATA_DIR);
  }();
  return dir;
}

}  // namespace penumbra::test

#define SKIP_WITHOUT_SHARED_DATA(file)                                      \
  if (!std::filesystem::exists(::penumbra::test::shared_data_dir() + "/" file)) \
  GTEST_SKIP() << ::penumbra::test::shared_data_dir() << "/" file << " not found (set PENUMBRA_DATA_DIR)"
