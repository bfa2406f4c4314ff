// `penumbra info` for trajectories: see info_trajectory.h.
#include "info_trajectory.h"

#include <chrono>
#include <cstdio>
#include <fstream>
#include <memory>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/replace_file.h"
#include "penumbra/data/io/trajectory_io.h"

namespace penumbra::cli {
namespace {

std::string box_str(const TrajectoryFrame& f) {
  if (!f.has_box) return "none";
  char s[160];
  std::snprintf(s, sizeof s, "%.9g %.9g %.9g %.9g %.9g %.9g (a b c in angstrom, alpha beta gamma in degrees)", f.box[0], f.box[1],
                f.box[2], f.box[3], f.box[4], f.box[5]);
  return s;
}

bool has_suffix(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

// NumPy's .npy (format 1.0): little-endian float32, shape (atoms, 3); or text, one "x y z" per line.
void write_positions(const std::string& path, const std::vector<Vec3>& p) {
  std::string bytes;
  if (has_suffix(path, ".npy")) {
    std::string header = "{'descr': '<f4', 'fortran_order': False, 'shape': (" + std::to_string(p.size()) + ", 3), }";
    header.append(64 - (10 + header.size() + 1) % 64, ' ');  // magic, version and length take 10 bytes
    header += '\n';
    bytes.append("\x93NUMPY\x01\x00", 8);
    bytes += static_cast<char>(header.size() & 0xff);
    bytes += static_cast<char>(header.size() >> 8);
    bytes += header;
    static_assert(sizeof(Vec3) == 12, "Vec3 is three packed floats");
    bytes.append(reinterpret_cast<const char*>(p.data()), p.size() * sizeof(Vec3));
  } else if (has_suffix(path, ".txt")) {
    char line[96];
    for (const Vec3& v : p) {
      std::snprintf(line, sizeof line, "%.9g %.9g %.9g\n", v.x, v.y, v.z);
      bytes += line;
    }
  } else {
    throw Error("--positions: " + path + " must end in .npy or .txt");
  }
  with_context("--positions " + path, [&] { replace_file_contents(path, bytes); });
}

}  // namespace

void info_trajectory(const TrajectoryInfoOptions& o) {
  std::unique_ptr<TrajectoryReader> r = open_trajectory(o.file);
  TrajectoryFrame first, last;
  r->read_frame(0, first);
  r->read_frame(r->frame_count() - 1, last);
  std::printf("file        %s\n", o.file.c_str());
  std::printf("format      %s\n", r->format().c_str());
  std::printf("atoms       %zu\n", r->atom_count());
  std::printf("frames      %zu\n", r->frame_count());
  const bool no_time = r->format() == "pdb" || r->format() == "xyz";
  std::printf("time        %.9g .. %.9g ps (steps %lld .. %lld)%s\n", first.time_ps, last.time_ps, static_cast<long long>(first.step),
              static_cast<long long>(last.step), no_time ? "; the format stores no time: frame indices" : "");
  std::printf("box         %s\n", box_str(first).c_str());
  std::printf("memory      %zu bytes (reader index and buffers)\n", r->memory_bytes());
  if (o.frame >= 0 || !o.positions.empty()) {
    const std::size_t k = o.frame >= 0 ? static_cast<std::size_t>(o.frame) : 0;
    TrajectoryFrame f;
    r->read_frame(k, f);
    std::printf("frame       %zu: time %.9g ps, step %lld\n", k, f.time_ps, static_cast<long long>(f.step));
    std::printf("frame box   %s\n", box_str(f).c_str());
    if (!o.positions.empty()) {
      write_positions(o.positions, f.positions);
      std::printf("positions   %s (%zu atoms, angstrom)\n", o.positions.c_str(), f.positions.size());
    }
  }
  if (o.read_all) {
    TrajectoryFrame f;
    const auto t0 = std::chrono::steady_clock::now();
    for (std::size_t k = 0; k < r->frame_count(); ++k) r->read_frame(k, f);
    const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    std::printf("read        %zu frames in %.3f s (%.1f frames/s; memory %zu bytes)\n", r->frame_count(), s,
                static_cast<double>(r->frame_count()) / s, r->memory_bytes());
  }
}

}  // namespace penumbra::cli
