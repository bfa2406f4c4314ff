// Shared by the trajectory readers (trajectory_*.cpp): the per-file reader interface the list reader
// drives, a checked binary file, and the unit-cell conversions MDAnalysis uses.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <memory>
#include <string>

#include "penumbra/core/error.h"
#include "penumbra/data/io/trajectory_io.h"

namespace penumbra::traj_detail {

// One file's reader. release() closes the file and drops the frame buffers (the index stays); the next
// read_frame opens it again. The list reader keeps only the file it reads from open.
class TrajectoryFile : public TrajectoryReader {
public:
  virtual bool stores_time() const = 0;  // false: time_ps and step are the frame index
  virtual void release() = 0;
};

std::unique_ptr<TrajectoryFile> open_xtc(const std::string& path, std::size_t expected_atoms);
std::unique_ptr<TrajectoryFile> open_dcd(const std::string& path, std::size_t expected_atoms);
// format: "pdb", "xyz" or "gro"
std::unique_ptr<TrajectoryFile> open_text_trajectory(const std::string& path, const std::string& format, std::size_t expected_atoms);
// Multi-model mmCIF (trajectory_mmcif.cpp): parsed whole through gemmi at open, every model's positions held.
std::unique_ptr<TrajectoryFile> open_mmcif(const std::string& path, std::size_t expected_atoms);

inline std::string frame_str(std::size_t k) { return "frame " + std::to_string(k); }

// "frame K holds N atoms, but the topology has M" when expected > 0 and found differs.
inline void check_atoms(std::size_t frame, std::uint64_t found, std::size_t expected) {
  if (expected > 0 && found != expected)
    throw Error(frame_str(frame) + " holds " + std::to_string(found) + " atoms, but " + std::to_string(expected) +
                " were expected (the topology's atom count)");
}

// A binary file opened for reading, closed on destruction; reads are all-or-nothing.
class BinaryFile {
public:
  BinaryFile() = default;
  explicit BinaryFile(const std::string& path) : f_(std::fopen(path.c_str(), "rb")) {
    if (!f_) throw Error("cannot open the file");
  }
  ~BinaryFile() { close(); }
  BinaryFile(const BinaryFile&) = delete;
  BinaryFile& operator=(const BinaryFile&) = delete;
  BinaryFile(BinaryFile&& o) noexcept : f_(o.f_) { o.f_ = nullptr; }
  BinaryFile& operator=(BinaryFile&& o) noexcept {
    if (this != &o) { close(); f_ = o.f_; o.f_ = nullptr; }
    return *this;
  }
  bool is_open() const { return f_ != nullptr; }
  void close() {
    if (f_) std::fclose(f_);
    f_ = nullptr;
  }
  void seek(std::uint64_t offset) {
    if (std::fseek(f_, static_cast<long>(offset), SEEK_SET) != 0) throw Error("cannot seek to byte " + std::to_string(offset));
  }
  // Reads n bytes at the current position; false when the file ends first.
  bool read(void* out, std::size_t n) { return std::fread(out, 1, n, f_) == n; }

private:
  std::FILE* f_ = nullptr;
};

// MDAnalysis' `triclinic_box`: edge lengths and angles (degrees) of three cell vectors, computed in
// double precision and rounded to float; an invalid cell (a length ≤ 0, an angle not in (0°, 180°))
// gives false.
bool cell_from_vectors(const double a[3], const double b[3], const double c[3], std::array<float, 6>& box);

}  // namespace penumbra::traj_detail
