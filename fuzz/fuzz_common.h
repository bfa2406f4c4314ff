// Shared by the libFuzzer targets: every reader takes a path, so the input is written to a file in a
// temporary directory (tmpfs when /dev/shm exists) and the reader is run on it. A reader
// may refuse the input only with penumbra::Error; anything else that escapes (a library exception, an
// abort, a sanitizer report, a leak) is a finding.
#pragma once

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "penumbra/core/error.h"

namespace penumbra::fuzz {

// $PENUMBRA_FUZZ_TMP (scripts/fuzz.sh makes and removes it) or /dev/shm/penumbra-fuzz-<pid>.
inline const std::filesystem::path& work_dir() {
  static const std::filesystem::path dir = [] {
    const char* env = std::getenv("PENUMBRA_FUZZ_TMP");
    std::filesystem::path base = std::filesystem::exists("/dev/shm") ? "/dev/shm" : std::filesystem::temp_directory_path();
    std::filesystem::path d = env && *env ? std::filesystem::path(env) : base / ("penumbra-fuzz-" + std::to_string(::getpid()));
    std::filesystem::create_directories(d);
    // A small data file that detached headers ("data file: d.raw") can name.
    std::ofstream raw(d / "d.raw", std::ios::binary);
    for (int i = 0; i < 4096; ++i) raw.put(static_cast<char>(i * 37));
    return d;
  }();
  return dir;
}

// Writes bytes to work_dir()/name and returns the path.
inline std::string write_input(const std::string& name, const std::uint8_t* data, std::size_t size) {
  const std::string path = (work_dir() / name).string();
  std::FILE* f = std::fopen(path.c_str(), "wb");
  if (!f) std::abort();
  if (size && std::fwrite(data, 1, size, f) != size) std::abort();
  std::fclose(f);
  return path;
}

// Runs f; penumbra::Error is the reader's way to refuse input. Its message must not be empty.
template <class F>
void expect_error_or_result(F&& f) {
  try {
    f();
  } catch (const penumbra::Error& e) {
    if (e.what()[0] == '\0') std::abort();
  }
}

}  // namespace penumbra::fuzz
