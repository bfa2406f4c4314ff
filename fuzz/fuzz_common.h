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
#include <array>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/data/io/volume_io.h"

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

// Differential check of windows (load_volume_window) against the whole read: when `paths` read whole,
// windows of their slices — in a pass, in order and then out of order, and alone — must hold the same
// voxels, or be read whole and cut; a window that fails where the whole read did not is a finding too.
// Volumes of over 2^16 voxels are left out (time: a few KB of gzip input make megabytes of voxels).
inline void expect_windows_match(const std::vector<std::string>& paths, const penumbra::VolumeLoadOptions& options) {
  penumbra::Volume whole;
  try {
    whole = penumbra::load_volume(paths, options);
  } catch (const penumbra::Error&) {
    return;
  }
  const int n = whole.dims()[2];
  if (n < 2 || whole.is_bricked() || whole.voxel_count() > (std::size_t{1} << 16)) return;
  const auto check = [&](int first, int count) {
    penumbra::WindowRead read;
    const penumbra::Volume w = penumbra::load_volume_window(paths, options, [&](const std::array<int, 3>& dims) {
      if (dims != whole.dims()) std::abort();
      return penumbra::SliceRange{first, count};
    }, read);
    if (w.dims()[0] != whole.dims()[0] || w.dims()[1] != whole.dims()[1] || w.dims()[2] != count || w.type() != whole.type()) std::abort();
    for (int k = 0; k < count; ++k)
      for (int j = 0; j < w.dims()[1]; ++j)
        for (int i = 0; i < w.dims()[0]; ++i)
          if (w.value(i, j, k) != whole.value(i, j, k + first)) std::abort();
  };
  try {
    {
      const penumbra::WindowPass pass;
      check(0, n / 2);
      check(n / 2, n - n / 2);
      check(0, 1);
      check(n - 1, 1);
    }
    check(1, n - 1);
  } catch (const penumbra::Error&) {
    std::abort();
  }
}

}  // namespace penumbra::fuzz
