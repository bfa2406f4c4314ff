// Volume files larger than their memory budget, read reduced a slab at a time (volume_reduction.h).
#include "penumbra/data/io/volume_reduction.h"

#include <algorithm>
#include <cmath>
#include <cstring>

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

// The file's grid and voxel type (its level 0), from its header and one slice; nullopt for a layout read
// only whole (an NRRD whose z is another file axis).
std::optional<LevelGrid> file_grid(const std::string& path, const VolumeLoadOptions& unbudgeted) {
  LevelGrid g;
  WindowRead read;
  const Volume first = load_volume_window({path}, unbudgeted, [&](const std::array<int, 3>& d) {
    g.dims = d;
    return SliceRange{0, 1};
  }, read);
  if (read.whole) return std::nullopt;
  g.type = first.type();
  g.spacing = first.spacing();
  g.origin = first.origin();
  return g;
}

// The reduction by `f` of the file's grid: the factor per axis, its dims, spacing and origin.
struct Reduction {
  std::array<int, 3> k{};
  std::array<std::int64_t, 3> dims{};
  Vec3 spacing, origin;
};
Reduction reduction(const LevelGrid& g, int f) {
  Reduction r;
  r.k = factors(g.dims, f);
  r.dims = reduced_dims(g.dims, r.k);
  const Vec3& s = g.spacing;
  r.spacing = Vec3(s.x * static_cast<float>(r.k[0]), s.y * static_cast<float>(r.k[1]), s.z * static_cast<float>(r.k[2]));
  r.origin = Vec3(g.origin.x + 0.5f * static_cast<float>(r.k[0] - 1) * s.x, g.origin.y + 0.5f * static_cast<float>(r.k[1] - 1) * s.y,
                  g.origin.z + 0.5f * static_cast<float>(r.k[2] - 1) * s.z);
  return r;
}

VolumeLoadOptions without_budget(const VolumeLoadOptions& options) {
  VolumeLoadOptions unbudgeted = options;
  unbudgeted.memory_budget = 0;
  return unbudgeted;
}

// Reduced voxels [lo, hi) (whose z lies in [z_lo, z_hi)) of `r` into `out` (dims hi - lo), read from the
// file a slab of whole blocks at a time: each the mean of its block, summed in z, y, x order in double
// (the same arithmetic for the whole reduction and for any box of it, so that a box equals that part of
// the whole exactly). Returns the bytes read.
std::uint64_t read_block_means(const std::string& path, const VolumeLoadOptions& unbudgeted, const LevelGrid& g, const Reduction& r,
                               const std::array<std::int64_t, 3>& lo, const std::array<std::int64_t, 3>& hi, std::int64_t z_lo,
                               std::int64_t z_hi, Volume& out) {
  const std::array<int, 3>& k = r.k;
  const std::int64_t slice_bytes = std::int64_t{g.dims[0]} * g.dims[1] * static_cast<std::int64_t>(scalar_size(g.type));
  const std::int64_t slab = std::max<std::int64_t>(k[2], kSlabBytes / std::max<std::int64_t>(slice_bytes, 1) / k[2] * k[2]);
  const std::int64_t bx = hi[0] - lo[0], by = hi[1] - lo[1];
  std::uint64_t bytes = 0;
  const WindowPass pass;  // gzip data decompressed once, slab after slab
  for (std::int64_t z0 = z_lo * k[2]; z0 < std::min<std::int64_t>(z_hi * k[2], g.dims[2]); z0 += slab) {
    const int count = static_cast<int>(std::min<std::int64_t>({slab, g.dims[2] - z0, z_hi * k[2] - z0}));
    WindowRead part_read;
    const Volume part = load_volume_window({path}, unbudgeted, [&](const std::array<int, 3>&) { return SliceRange{static_cast<int>(z0), count}; },
                                           part_read);
    bytes += part_read.bytes_read;
    const std::int64_t oz0 = z0 / k[2], oz1 = (z0 + count + k[2] - 1) / k[2];
    out.with_voxel_type([&](auto t) {
      using T = decltype(t);
      const T* src = part.data_as<T>();
      T* dst = out.data_as<T>();
      const std::size_t rows = static_cast<std::size_t>((oz1 - oz0) * by);
      parallel_for(rows, [&](std::size_t r0, std::size_t r1) {
        for (std::size_t row = r0; row < r1; ++row) {
          const std::int64_t oz = oz0 + static_cast<std::int64_t>(row) / by, oy = lo[1] + static_cast<std::int64_t>(row) % by;
          const std::int64_t zb = oz * k[2] - z0, ze = std::min<std::int64_t>(zb + k[2], count);
          const std::int64_t yb = oy * k[1], ye = std::min<std::int64_t>(yb + k[1], g.dims[1]);
          T* line = dst + static_cast<std::size_t>(((oz - lo[2]) * by + (oy - lo[1])) * bx);
          for (std::int64_t ox = lo[0]; ox < hi[0]; ++ox) {
            const std::int64_t xb = ox * k[0], xe = std::min<std::int64_t>(xb + k[0], g.dims[0]);
            double sum = 0;
            for (std::int64_t z = zb; z < ze; ++z)
              for (std::int64_t y = yb; y < ye; ++y) {
                const T* src_row = src + (z * g.dims[1] + y) * g.dims[0];
                for (std::int64_t x = xb; x < xe; ++x) sum += static_cast<double>(src_row[x]);
              }
            const double mean = sum / static_cast<double>((ze - zb) * (ye - yb) * (xe - xb));
            T& v = line[ox - lo[0]];
            if constexpr (std::is_floating_point_v<T>) v = static_cast<T>(mean);
            else v = static_cast<T>(std::floor(mean + 0.5));
          }
        }
      });
    });
  }
  return bytes;
}

}  // namespace

std::optional<Volume> load_reduced_to_fit(const std::string& path, const VolumeLoadOptions& options, VolumeFileInfo& info) {
  // a Zarr store chooses among its own levels (zarr_loader.cpp)
  if (options.memory_budget == 0 || is_zarr_store(path) || !reads_slices_in_part({path}, options)) return std::nullopt;
  const VolumeLoadOptions unbudgeted = without_budget(options);
  const std::optional<LevelGrid> grid = file_grid(path, unbudgeted);
  if (!grid) return std::nullopt;
  const std::array<int, 3>& dims = grid->dims;
  const ScalarType type = grid->type;
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
  const Reduction r = reduction(*grid, f);
  const std::array<std::int64_t, 3>& rd = r.dims;
  Volume out(type, {static_cast<int>(rd[0]), static_cast<int>(rd[1]), static_cast<int>(rd[2])}, r.spacing, r.origin, VoxelFill::Uninitialized);
  read_block_means(path, unbudgeted, *grid, r, {0, 0, 0}, rd, 0, rd[2], out);
  out.recompute_range();
  // opacities refer to the file's voxel, so that the reduced volume shows the same matter (as a pyramid's level)
  const Vec3& s = grid->spacing;
  out.set_opacity_length(std::min({std::abs(s.x), std::abs(s.y), std::abs(s.z)}));
  const std::array<int, 3>& k = r.k;
  info.format = volume_format({path});
  info.notes.push_back("reduced " + std::to_string(f) + "× to " + std::to_string(rd[0]) + "×" + std::to_string(rd[1]) + "×" + std::to_string(rd[2]) +
                       " (each voxel the mean of a " + std::to_string(k[0]) + "×" + std::to_string(k[1]) + "×" + std::to_string(k[2]) +
                       " block, read a slab at a time): the file's " + dims_text(dims) + " " + to_string(type) + " voxels hold " +
                       byte_size_string(whole_bytes) + ", over the memory budget of " + byte_size_string(budget) +
                       "; `penumbra convert` writes an OME-Zarr pyramid whose levels 'level' chooses");
  return out;
}

std::vector<LevelGrid> reduced_level_grids(const std::string& path, const VolumeLoadOptions& options, const Volume& opened) {
  if (is_zarr_store(path) || !reads_slices_in_part({path}, options)) return {};
  const std::optional<LevelGrid> grid = file_grid(path, without_budget(options));
  if (!grid || grid->type != opened.type()) return {};
  std::vector<LevelGrid> levels;
  const int longest = std::max({grid->dims[0], grid->dims[1], grid->dims[2]});
  for (int f = 1;; f *= 2) {
    const Reduction r = reduction(*grid, f);
    const std::array<int, 3> d{static_cast<int>(r.dims[0]), static_cast<int>(r.dims[1]), static_cast<int>(r.dims[2])};
    levels.push_back({d, r.spacing, r.origin, grid->type});
    if (d == opened.dims() && length(r.spacing - opened.spacing()) <= 1e-4f * length(r.spacing)) return levels;
    if (f >= longest) return {};
  }
}

Volume load_reduced_box(const std::string& path, const VolumeLoadOptions& options, const LevelGrid& file_level, int level,
                        const std::array<std::int64_t, 3>& lo, const std::array<std::int64_t, 3>& hi, WindowRead* read, const HeldBox* held) {
  return with_context(path, [&] {
    const VolumeLoadOptions unbudgeted = without_budget(options);
    if (level < 0 || level > 30) throw Error("level " + std::to_string(level) + " (expected 0 to 30)");
    const Reduction r = reduction(file_level, 1 << level);
    for (std::size_t a = 0; a < 3; ++a)
      if (lo[a] < 0 || hi[a] > r.dims[a] || lo[a] >= hi[a])
        throw Error("box [" + std::to_string(lo[0]) + "," + std::to_string(lo[1]) + "," + std::to_string(lo[2]) + ")-(" +
                    std::to_string(hi[0]) + "," + std::to_string(hi[1]) + "," + std::to_string(hi[2]) + ") is not inside level " +
                    std::to_string(level) + "'s " + std::to_string(r.dims[0]) + "×" + std::to_string(r.dims[1]) + "×" +
                    std::to_string(r.dims[2]) + " voxels");
    const std::array<int, 3> d{static_cast<int>(hi[0] - lo[0]), static_cast<int>(hi[1] - lo[1]), static_cast<int>(hi[2] - lo[2])};
    const Vec3 origin = r.origin + r.spacing * Vec3(static_cast<float>(lo[0]), static_cast<float>(lo[1]), static_cast<float>(lo[2]));
    // slices of the box that a box held before covers in x and y are copied from it (or, when it gives
    // its voxels up, are in place already); the rest is read
    std::int64_t copy_lo = lo[2], copy_hi = lo[2];
    const bool covers = held && held->voxels && held->voxels->type() == file_level.type && !held->voxels->is_bricked() &&
                        held->lo[0] <= lo[0] && held->hi[0] >= hi[0] && held->lo[1] <= lo[1] && held->hi[1] >= hi[1];
    if (covers) {
      copy_lo = std::max(lo[2], held->lo[2]);
      copy_hi = std::min(hi[2], held->hi[2]);
      if (copy_lo >= copy_hi) copy_lo = copy_hi = lo[2];
    }
    std::optional<Volume> taken = take_held_storage(held, file_level.type, lo, hi);
    const bool in_place = taken.has_value();
    Volume out = in_place ? std::move(*taken) : Volume(file_level.type, d, r.spacing, origin, VoxelFill::Uninitialized);
    if (in_place) {
      out.set_spacing(r.spacing);
      out.set_origin(origin);
    }
    std::uint64_t bytes_read = 0, bytes_reused = 0;
    if (copy_lo > lo[2]) bytes_read += read_block_means(path, unbudgeted, file_level, r, lo, hi, lo[2], copy_lo, out);
    if (copy_hi < hi[2]) bytes_read += read_block_means(path, unbudgeted, file_level, r, lo, hi, std::max(copy_hi, lo[2]), hi[2], out);
    if (copy_hi > copy_lo && !in_place) {
      const std::size_t size = scalar_size(file_level.type);
      const std::int64_t hx = held->hi[0] - held->lo[0], hy = held->hi[1] - held->lo[1];
      const std::byte* src = held->voxels->data();
      std::byte* dst = out.data();
      for (std::int64_t z = copy_lo; z < copy_hi; ++z)
        for (std::int64_t y = lo[1]; y < hi[1]; ++y)
          std::memcpy(dst + static_cast<std::size_t>(((z - lo[2]) * d[1] + (y - lo[1])) * d[0]) * size,
                      src + static_cast<std::size_t>(((z - held->lo[2]) * hy + (y - held->lo[1])) * hx + (lo[0] - held->lo[0])) * size,
                      static_cast<std::size_t>(d[0]) * size);
    }
    if (copy_hi > copy_lo)
      bytes_reused = static_cast<std::uint64_t>(copy_hi - copy_lo) * static_cast<std::uint64_t>(d[0]) * static_cast<std::uint64_t>(d[1]) *
                     scalar_size(file_level.type);
    if (read) {
      read->bytes_read = bytes_read;
      read->bytes_reused = bytes_reused;
    }
    out.recompute_range();
    const Vec3& s = file_level.spacing;
    out.set_opacity_length(std::min({std::abs(s.x), std::abs(s.y), std::abs(s.z)}));
    return out;
  });
}

}  // namespace penumbra
