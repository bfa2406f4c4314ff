// Raw volumes: a headerless dump of voxels whose dimensions, type and byte order the caller gives.
// Nothing in the file can confirm them, so the file size is the one check there is: it must equal
// header_bytes plus the voxel data exactly, which catches wrong dims or type as well as truncation.
#include <algorithm>
#include <bit>
#include <climits>
#include <fstream>

#include "penumbra/data/io/byte_order.h"
#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/volume_io.h"

namespace penumbra {

namespace {

std::string dims_str(const std::array<std::int64_t, 3>& d) {
  return std::to_string(d[0]) + "x" + std::to_string(d[1]) + "x" + std::to_string(d[2]);
}

}  // namespace

Volume load_raw_volume(const std::string& path, const RawVolumeOptions& options) { return load_raw_volume(path, options, nullptr, nullptr); }

Volume load_raw_volume(const std::string& path, const RawVolumeOptions& options, const SliceChooser* choose, WindowRead* read) {
  using io_detail::bytes_str;
  const std::size_t count = checked_voxel_count(options.dims);
  for (int a = 0; a < 3; ++a)
    if (options.dims[a] > INT_MAX) throw Error("dimension " + std::to_string(a) + " is too large: " + dims_str(options.dims));
  const std::size_t voxel_size = scalar_size(options.type);
  // count <= 2^34 and voxel_size <= 4, so this cannot overflow.
  const std::uint64_t data_bytes = static_cast<std::uint64_t>(count) * voxel_size;

  const std::uint64_t file_bytes = io_detail::regular_file_size(path);
  if (options.header_bytes > file_bytes || file_bytes - options.header_bytes != data_bytes) {
    const bool short_file = options.header_bytes > file_bytes || file_bytes - options.header_bytes < data_bytes;
    throw Error("raw file has " + bytes_str(file_bytes) + " but expected " + bytes_str(options.header_bytes + data_bytes) +
                " (" + std::to_string(options.header_bytes) + " header bytes + " + dims_str(options.dims) + " " +
                to_string(options.type) + " voxels of " + std::to_string(voxel_size) + " bytes); the file is " +
                (short_file ? "truncated" : "longer than the data") + " or the dims/type are wrong");
  }

  const std::array<int, 3> dims{static_cast<int>(options.dims[0]), static_cast<int>(options.dims[1]), static_cast<int>(options.dims[2])};
  const SliceRange slices = choose ? checked_slices(*choose, dims) : SliceRange{0, dims[2]};
  const std::uint64_t slice_bytes = static_cast<std::uint64_t>(dims[0]) * static_cast<std::uint64_t>(dims[1]) * voxel_size;
  const std::uint64_t bytes = slice_bytes * static_cast<std::uint64_t>(slices.count);
  Volume volume(options.type, {dims[0], dims[1], slices.count}, options.spacing, {0, 0, 0},
                VoxelFill::Uninitialized);  // the read below fills every voxel
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open the file for reading");
  in.seekg(static_cast<std::streamoff>(options.header_bytes + slice_bytes * static_cast<std::uint64_t>(slices.first)));
  in.read(reinterpret_cast<char*>(volume.data()), static_cast<std::streamsize>(bytes));
  if (!in || static_cast<std::uint64_t>(in.gcount()) != bytes)
    throw Error("read only " + bytes_str(static_cast<std::uint64_t>(in.gcount())) + " of " + bytes_str(bytes) + " of voxel data");
  if (options.big_endian != (std::endian::native == std::endian::big)) io_detail::swap_bytes(volume.data(), volume.voxel_count(), voxel_size);
  volume.recompute_range();  // rejects NaN/inf in float data and gives the volume its range
  if (slices.count < dims[2]) volume.set_window(slices.first, dims[2]);
  if (read) *read = WindowRead{bytes, false};
  return volume;
}

}  // namespace penumbra
