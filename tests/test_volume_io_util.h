// Helpers for the volume loader tests: a per-test temporary directory, and writers for small NRRD and
// NIfTI-1 files made byte by byte (independently of teem and niftilib, so the loaders are tested
// against the formats, not against themselves).
#pragma once

#include <gtest/gtest.h>
#include <nifti/nifti1.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/io/zarr_writer.h"

namespace penumbra::test {

// True when one of the loader's notes contains `part`.
// An OME-Zarr pyramid of 8³ chunks written at `path` from a uint16 volume of `dims` whose voxel i holds
// i·37 mod 4001 (spacing 0.5, 0.75, 1.25; origin 3, −2, 1): every voxel tells where it came from.
inline void write_numbered_pyramid(const std::string& path, const std::array<int, 3>& dims) {
  Volume source(ScalarType::UInt16, dims, {0.5f, 0.75f, 1.25f}, {3, -2, 1});
  for (std::size_t i = 0; i < source.voxel_count(); ++i) source.set_value(i, static_cast<float>(i * 37 % 4001));
  source.recompute_range();
  OmeZarrWriteOptions options;
  options.chunk = 8;
  write_ome_zarr(source, path, options);
}

inline bool has_note(const VolumeFileInfo& info, const std::string& part) {
  return std::any_of(info.notes.begin(), info.notes.end(), [&](const std::string& n) { return n.find(part) != std::string::npos; });
}

using Bytes = std::vector<std::uint8_t>;

// A directory named after the running test, removed (with its contents) when the test ends.
class TempDir {
public:
  TempDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    const std::string name = std::string("penumbra_") + info->test_suite_name() + "_" + info->name() + "_" +
                             std::to_string(::getpid());
    path_ = std::filesystem::temp_directory_path() / name;
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
  std::string file(const std::string& name) const { return (path_ / name).string(); }

private:
  std::filesystem::path path_;
};

inline void write_file(const std::string& path, const Bytes& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()), static_cast<std::streamsize>(bytes.size()));
  if (!out) throw std::runtime_error("cannot write " + path);
}

inline void write_file(const std::string& path, const std::string& text) { write_file(path, Bytes(text.begin(), text.end())); }

inline Bytes read_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return Bytes(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

inline Bytes concat(const Bytes& a, const Bytes& b) {
  // Sized once and copied into (rather than insert()) to dodge a GCC 12 -Warray-bounds false positive.
  Bytes out(a.size() + b.size());
  std::copy(a.begin(), a.end(), out.begin());
  std::copy(b.begin(), b.end(), out.begin() + static_cast<std::ptrdiff_t>(a.size()));
  return out;
}

// gzip (not zlib) framing, as NRRD's gzip encoding and .nii.gz use.
inline Bytes gzip(const Bytes& in) {
  z_stream zs{};
  if (deflateInit2(&zs, Z_BEST_COMPRESSION, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK)
    throw std::runtime_error("deflateInit2 failed");
  Bytes out(deflateBound(&zs, static_cast<uLong>(in.size())) + 64);
  zs.next_in = const_cast<Bytef*>(in.data());
  zs.avail_in = static_cast<uInt>(in.size());
  zs.next_out = out.data();
  zs.avail_out = static_cast<uInt>(out.size());
  const int rc = deflate(&zs, Z_FINISH);
  deflateEnd(&zs);
  if (rc != Z_STREAM_END) throw std::runtime_error("deflate failed");
  out.resize(zs.total_out);
  return out;
}

// Values as bytes in the given byte order.
template <class T>
Bytes to_bytes(const std::vector<T>& values, bool big_endian = false) {
  Bytes out(values.size() * sizeof(T));
  std::memcpy(out.data(), values.data(), out.size());
  if (big_endian && sizeof(T) > 1)
    for (std::size_t i = 0; i < values.size(); ++i)
      for (std::size_t b = 0; b < sizeof(T) / 2; ++b) std::swap(out[i * sizeof(T) + b], out[i * sizeof(T) + sizeof(T) - 1 - b]);
  return out;
}

// An attached NRRD: magic, the given header lines (each ending in \n), a blank line, then the data.
inline Bytes nrrd_file(const std::string& header_lines, const Bytes& data) {
  const std::string head = "NRRD0004\n" + header_lines + "\n";
  return concat(Bytes(head.begin(), head.end()), data);
}

struct NiftiSpec {
  std::array<short, 8> dim{3, 4, 3, 2, 1, 1, 1, 1};
  short datatype = DT_INT16;
  short bitpix = 16;
  std::array<float, 3> pixdim{1.5f, 2.0f, 2.5f};
  float slope = 0, inter = 0;
  std::array<float, 3> qoffset{0, 0, 0};  // the LPS origin (written as NIfTI's RAS: x and y negated)
  bool big_endian = false;  // header and voxels in big-endian byte order (pass big-endian voxel bytes)
};

template <class T>
void swap_in_place(T& v) {
  auto* b = reinterpret_cast<unsigned char*>(&v);
  for (std::size_t i = 0; i < sizeof(T) / 2; ++i) std::swap(b[i], b[sizeof(T) - 1 - i]);
}

// Byte-swaps the header fields these tests set (the others are zero, the same either way).
inline void swap_header(nifti_1_header& h) {
  swap_in_place(h.sizeof_hdr);
  for (auto& d : h.dim) swap_in_place(d);
  for (auto& p : h.pixdim) swap_in_place(p);
  swap_in_place(h.datatype);
  swap_in_place(h.bitpix);
  swap_in_place(h.vox_offset);
  swap_in_place(h.scl_slope);
  swap_in_place(h.scl_inter);
  swap_in_place(h.qform_code);
  swap_in_place(h.quatern_d);
  swap_in_place(h.qoffset_x);
  swap_in_place(h.qoffset_y);
  swap_in_place(h.qoffset_z);
}

// A single-file NIfTI-1 (.nii): 348-byte header, 4 zero extension bytes, then the voxels as given.
inline Bytes nifti_file(const NiftiSpec& spec, const Bytes& data) {
  static_assert(sizeof(nifti_1_header) == 348);
  nifti_1_header h{};
  h.sizeof_hdr = 348;
  for (int i = 0; i < 8; ++i) h.dim[i] = spec.dim[static_cast<std::size_t>(i)];
  h.datatype = spec.datatype;
  h.bitpix = spec.bitpix;
  h.pixdim[0] = 1;
  for (int i = 0; i < 3; ++i) h.pixdim[i + 1] = spec.pixdim[static_cast<std::size_t>(i)];
  h.vox_offset = 352;
  h.scl_slope = spec.slope;
  h.scl_inter = spec.inter;
  h.xyzt_units = NIFTI_UNITS_MM;
  // The qform turns the grid by 180° about z (quaternion d = 1): RAS diag(-1, -1, 1), which is LPS's
  // identity, so the voxels load in file order.
  h.qform_code = 1;
  h.quatern_b = h.quatern_c = 0;
  h.quatern_d = 1;
  h.qoffset_x = -spec.qoffset[0];
  h.qoffset_y = -spec.qoffset[1];
  h.qoffset_z = spec.qoffset[2];
  std::memcpy(h.magic, "n+1\0", 4);
  if (spec.big_endian) swap_header(h);
  Bytes out(352, 0);
  std::memcpy(out.data(), &h, sizeof h);
  return concat(out, data);
}

}  // namespace penumbra::test
