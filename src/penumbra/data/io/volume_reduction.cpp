// Volume files larger than their memory budget, read reduced a slab at a time (volume_reduction.h).
#include "penumbra/data/io/volume_reduction.h"

#include <algorithm>
#include <cmath>

#include "penumbra/core/byte_size.h"
#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/data/io/text_fields.h"

namespace penumbra {

namespace {

// Slices read at a time: about this many bytes, a whole number of blocks.
constexpr std::int64_t kSlabBytes = std::int64_t{16} << 20;

std::array<std::int64_t, 3> reduced_dims(const std::array<int, 3>& dims, const std::array<int, 3>& factor) {
  return {(dims[0] + factor[0] - 1) / factor[0], (dims[1] + factor[1] - 1) / factor[1], (dims[2] + factor[2] - 1) / factor[2]};
}

// The factor per axis for a reduction by `f`: an axis shorter than f is one block.
std::array<int, 3> factors(const std::array<int, 3>& dims, int f) {
  return {std::min(f, dims[0]), std::min(f, dims[1]), std::min(f, dims[2])};
}

std::string dims_text(const std::array<int, 3>& d) {
  return std::to_string(d[0]) + "×" + std::to_string(d[1]) + "×" + std::to_string(d[2]);
}

}  // namespace

std::optional<Volume> load_reduced_to_fit(const std::string& path, const VolumeLoadOptions& options, VolumeFileInfo& info) {
  // a Zarr store chooses among its own levels (zarr_loader.cpp)
  if (options.memory_budget == 0 || is_zarr_store(path) || !reads_slices_in_part({path}, options)) return std::nullopt;
  VolumeLoadOptions unbudgeted = options;
  unbudgeted.memory_budget = 0;
  // the grid and the voxel type: the header and one slice
  std::array<int, 3> dims{};
  WindowRead read;
  const Volume first = load_volume_window({path}, unbudgeted, [&](const std::array<int, 3>& d) {
    dims = d;
    return SliceRange{0, 1};
  }, read);
  if (read.whole) return std::nullopt;  // a layout read only whole (an NRRD whose z is another file axis)
  const ScalarType type = first.type();
  const std::uint64_t budget = options.memory_budget;
  const std::uint64_t whole_bytes = volume_held_bytes({dims[0], dims[1], dims[2]}, type);
  if (whole_bytes <= budget) return std::nullopt;
  int f = 2;
  const int longest = std::max({dims[0], dims[1], dims[2]});
  while (volume_held_bytes(reduced_dims(dims, factors(dims, f)), type) > budget) {
    if (f >= longest)
      throw Error(path + ": the file's " + dims_text(dims) + " " + to_string(type) + " voxels hold " + byte_size_string(whole_bytes) +
                  "; even reduced to one voxel along its longest axis they do not fit the memory budget of " + byte_size_string(budget));
    f *= 2;
  }
  const std::array<int, 3> k = factors(dims, f);
  const std::array<std::int64_t, 3> rd = reduced_dims(dims, k);
  const Vec3 s = first.spacing(), o = first.origin();
  const Vec3 spacing(s.x * static_cast<float>(k[0]), s.y * static_cast<float>(k[1]), s.z * static_cast<float>(k[2]));
  const Vec3 origin(o.x + 0.5f * static_cast<float>(k[0] - 1) * s.x, o.y + 0.5f * static_cast<float>(k[1] - 1) * s.y,
                    o.z + 0.5f * static_cast<float>(k[2] - 1) * s.z);
  Volume out(type, {static_cast<int>(rd[0]), static_cast<int>(rd[1]), static_cast<int>(rd[2])}, spacing, origin, VoxelFill::Uninitialized);
  const std::int64_t slice_bytes = std::int64_t{dims[0]} * dims[1] * static_cast<std::int64_t>(scalar_size(type));
  const std::int64_t slab = std::max<std::int64_t>(k[2], kSlabBytes / std::max<std::int64_t>(slice_bytes, 1) / k[2] * k[2]);
  const WindowPass pass;  // gzip data decompressed once, slab after slab
  for (std::int64_t z0 = 0; z0 < dims[2]; z0 += slab) {
    const int count = static_cast<int>(std::min<std::int64_t>(slab, dims[2] - z0));
    WindowRead part_read;
    const Volume part = load_volume_window({path}, unbudgeted, [&](const std::array<int, 3>&) { return SliceRange{static_cast<int>(z0), count}; },
                                           part_read);
    const std::int64_t oz0 = z0 / k[2], oz1 = (z0 + count + k[2] - 1) / k[2];
    out.with_voxel_type([&](auto t) {
      using T = decltype(t);
      const T* src = part.data_as<T>();
      T* dst = out.data_as<T>();
      const std::size_t rows = static_cast<std::size_t>((oz1 - oz0) * rd[1]);
      parallel_for(rows, [&](std::size_t r0, std::size_t r1) {
        for (std::size_t r = r0; r < r1; ++r) {
          const std::int64_t oz = oz0 + static_cast<std::int64_t>(r) / rd[1], oy = static_cast<std::int64_t>(r) % rd[1];
          const std::int64_t zb = oz * k[2] - z0, ze = std::min<std::int64_t>(zb + k[2], count);
          const std::int64_t yb = oy * k[1], ye = std::min<std::int64_t>(yb + k[1], dims[1]);
          for (std::int64_t ox = 0; ox < rd[0]; ++ox) {
            const std::int64_t xb = ox * k[0], xe = std::min<std::int64_t>(xb + k[0], dims[0]);
            double sum = 0;
            for (std::int64_t z = zb; z < ze; ++z)
              for (std::int64_t y = yb; y < ye; ++y) {
                const T* row = src + (z * dims[1] + y) * dims[0];
                for (std::int64_t x = xb; x < xe; ++x) sum += static_cast<double>(row[x]);
              }
            const double mean = sum / static_cast<double>((ze - zb) * (ye - yb) * (xe - xb));
            T& v = dst[static_cast<std::size_t>((oz * rd[1] + oy) * rd[0] + ox)];
            if constexpr (std::is_floating_point_v<T>) v = static_cast<T>(mean);
            else v = static_cast<T>(std::floor(mean + 0.5));
          }
        }
      });
    });
  }
  out.recompute_range();
  // opacities refer to the file's voxel, so that the reduced volume shows the same matter (as a pyramid's level)
  out.set_opacity_length(std::min({std::abs(s.x), std::abs(s.y), std::abs(s.z)}));
  info.format = volume_format({path});
  info.notes.push_back("reduced " + std::to_string(f) + "× to " + std::to_string(rd[0]) + "×" + std::to_string(rd[1]) + "×" + std::to_string(rd[2]) +
                       " (each voxel the mean of a " + std::to_string(k[0]) + "×" + std::to_string(k[1]) + "×" + std::to_string(k[2]) +
                       " block, read a slab at a time): the file's " + dims_text(dims) + " " + to_string(type) + " voxels hold " +
                       byte_size_string(whole_bytes) + ", over the memory budget of " + byte_size_string(budget) +
                       "; `penumbra convert` writes an OME-Zarr pyramid whose levels 'level' chooses");
  return out;
}

}  // namespace penumbra
