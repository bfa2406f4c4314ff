#include "penumbra/data/io/volume_placement.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <type_traits>
#include <utility>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"

namespace penumbra {

namespace {

using Vec3d = std::array<double, 3>;

std::string affine_number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.6g", v == 0 ? 0.0 : v);  // no "-0"
  return buf;
}

double norm(const Vec3d& v) { return std::sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2]); }

double determinant(const Affine& a) {
  const auto& m = a.linear;
  return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
         m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
}

// Error unless every entry is finite and the columns span the space.
void check_affine(const Affine& a) {
  for (const auto& row : a.linear)
    for (const double v : row)
      if (!std::isfinite(v)) throw Error("index-to-world affine " + a.str() + " is not finite");
  for (const double v : a.offset)
    if (!std::isfinite(v)) throw Error("index-to-world affine " + a.str() + " has a non-finite origin");
  for (const double v : a.offset)
    if (std::abs(v) > 1e15) throw Error("index-to-world affine " + a.str() + " has an origin beyond 1e15 mm");
  double scale = 1;
  for (int c = 0; c < 3; ++c) {
    const double spacing = norm(a.column(c));
    if (spacing > 1e12 || spacing < 1e-12)
      throw Error("index-to-world affine " + a.str() + " has a spacing of " + affine_number(spacing) + " mm along " + std::string(1, "ijk"[c]) +
                  " (expected 1e-12 to 1e12)");
    scale *= spacing;
  }
  if (!(scale > 0) || std::abs(determinant(a)) < 1e-6 * scale)
    throw Error("index-to-world affine " + a.str() + " is singular (expected three independent axes of non-zero spacing)");
}

// The largest angle, in degrees, between a file axis and the world axis nearest to it.
double largest_tilt(const Affine& a) {
  double tilt = 0;
  for (int c = 0; c < 3; ++c) {
    const Vec3d col = a.column(c);
    const double n = norm(col);
    const double cosine = std::max({std::abs(col[0]), std::abs(col[1]), std::abs(col[2])}) / n;
    tilt = std::max(tilt, std::acos(std::min(1.0, cosine)) * 180.0 / 3.14159265358979323846);
  }
  return tilt;
}

std::string axis_name(int file_axis) { return std::string(1, "ijk"[file_axis]); }

std::string orientation_text(const AxisPermutation& p) {
  std::string s;
  for (int w = 0; w < 3; ++w)
    s += std::string(w ? ", " : "") + "xyz"[w] + " = " + (p.reversed[w] ? "-" : "+") + axis_name(p.file_axis[w]);
  return s + " (the file's axes i, j, k reordered onto LPS +x, +y, +z)";
}

// The voxels reordered: stored voxel p is file voxel f with f[file_axis[w]] = reversed[w] ? n - 1 - p[w] : p[w].
template <class T>
void reorder_voxels(const Volume& in, const AxisPermutation& p, Volume& out) {
  const auto& fd = in.dims();
  const std::array<std::int64_t, 3> file_stride{1, fd[0], static_cast<std::int64_t>(fd[0]) * fd[1]};
  const auto& d = out.dims();
  std::int64_t base = 0;
  std::array<std::int64_t, 3> step{};
  for (int w = 0; w < 3; ++w) {
    const std::int64_t s = file_stride[p.file_axis[w]];
    step[w] = p.reversed[w] ? -s : s;
    if (p.reversed[w]) base += (d[w] - 1) * s;
  }
  const T* src = in.data_as<T>();
  T* dst = out.data_as<T>();
  parallel_for(static_cast<std::size_t>(d[2]), [&](std::size_t z0, std::size_t z1) {
    for (auto z = static_cast<std::int64_t>(z0); z < static_cast<std::int64_t>(z1); ++z)
      for (std::int64_t y = 0; y < d[1]; ++y) {
        const T* row = src + base + z * step[2] + y * step[1];
        T* o = dst + (z * d[1] + y) * d[0];
        for (std::int64_t x = 0; x < d[0]; ++x) o[x] = row[x * step[0]];
      }
  });
}

Vec3 to_vec3(const Vec3d& v) { return {static_cast<float>(v[0]), static_cast<float>(v[1]), static_cast<float>(v[2])}; }

Volume reordered(Volume file_grid, const Affine& affine, const AxisPermutation& p, VolumeFileInfo& info) {
  Vec3 spacing;
  for (int w = 0; w < 3; ++w) spacing[w] = static_cast<float>(norm(affine.column(p.file_axis[w])));
  const Vec3 origin = placed_origin(affine, file_grid.dims(), p);
  if (!is_finite(spacing) || !is_finite(origin) || !(spacing.x > 0 && spacing.y > 0 && spacing.z > 0))
    throw Error("index-to-world affine " + affine.str() + " gives spacing or origin outside the float range");
  if (p.identity()) {
    file_grid.set_spacing(spacing);
    file_grid.set_origin(origin);
    return file_grid;
  }
  if (info.orientation.empty()) info.orientation = orientation_text(p);
  if (file_grid.is_bricked())
    throw Error("the sparse grid's axes would need reordering (" + orientation_text(p) + "), which a sparse grid cannot be");
  Volume out(file_grid.type(), placed_dims(file_grid.dims(), p), spacing, origin, VoxelFill::Uninitialized);
  out.set_level_set(file_grid.level_set());
  file_grid.with_voxel_type([&](auto t) { reorder_voxels<decltype(t)>(file_grid, p, out); });
  return out;
}

// The inverse of the affine's linear part (checked non-singular before).
std::array<Vec3d, 3> inverse(const Affine& a) {
  const auto& m = a.linear;
  const double det = determinant(a);
  std::array<Vec3d, 3> r{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) {
      const int i1 = (j + 1) % 3, i2 = (j + 2) % 3, j1 = (i + 1) % 3, j2 = (i + 2) % 3;
      r[i][j] = (m[i1][j1] * m[i2][j2] - m[i1][j2] * m[i2][j1]) / det;
    }
  return r;
}

// Trilinear resampling onto the axis-aligned grid covering the world box of the voxel centres; outside
// the file's grid the value is the volume's smallest (its background).
Volume resampled(Volume file_grid, const Affine& affine, VolumeFileInfo& info) {
  if (file_grid.is_bricked())
    throw Error("the sparse grid's transform " + affine.str() + " is a rotation or shear, which a sparse grid cannot be resampled by");
  const auto& fd = file_grid.dims();
  Vec3d lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (int corner = 0; corner < 8; ++corner) {
    const Vec3d index{corner & 1 ? fd[0] - 1.0 : 0.0, corner & 2 ? fd[1] - 1.0 : 0.0, corner & 4 ? fd[2] - 1.0 : 0.0};
    const Vec3d w = affine.apply(index);
    for (int a = 0; a < 3; ++a) lo[a] = std::min(lo[a], w[a]), hi[a] = std::max(hi[a], w[a]);
  }
  double step = 1e300;
  for (int c = 0; c < 3; ++c)
    if (fd[c] > 1) step = std::min(step, norm(affine.column(c)));
  if (step == 1e300) step = norm(affine.column(0));
  // Counted in double first: a tiny step over a huge extent must be refused, not overflow an integer.
  std::array<double, 3> extent{};
  for (int a = 0; a < 3; ++a) extent[a] = std::floor((hi[a] - lo[a]) / step + 1e-6) + 1;
  const double bytes = extent[0] * extent[1] * extent[2] * static_cast<double>(scalar_size(file_grid.type()));
  const auto count_text = [](double n) { return n < 1e15 ? std::to_string(static_cast<std::int64_t>(n)) : affine_number(n); };
  const std::string grid_text = count_text(extent[0]) + "x" + count_text(extent[1]) + "x" + count_text(extent[2]);
  const bool representable = std::isfinite(bytes) && static_cast<float>(step) > 0 && std::isfinite(static_cast<float>(step)) &&
                             std::abs(lo[0]) < 1e30 && std::abs(lo[1]) < 1e30 && std::abs(lo[2]) < 1e30 &&
                             std::max({extent[0], extent[1], extent[2]}) < 2147483647.0;
  const double file_voxels = static_cast<double>(fd[0]) * static_cast<double>(fd[1]) * static_cast<double>(fd[2]);
  const double voxels = extent[0] * extent[1] * extent[2];
  if (representable && voxels > std::max(kMaxResampledGrowth * file_voxels, kResampledVoxelFloor))
    throw Error("the oblique volume (affine " + affine.str() + ") would be resampled onto an axis-aligned grid of " + grid_text +
                " voxels at its finest spacing, " + affine_number(step) + " mm: " + affine_number(voxels / file_voxels) +
                " times its own " + std::to_string(fd[0]) + "x" + std::to_string(fd[1]) + "x" + std::to_string(fd[2]) + " (at most " +
                affine_number(kMaxResampledGrowth) + " times; are the spacings in the header right?)");
  if (!representable || bytes > static_cast<double>(kMaxResampledBytes))
    throw Error("the oblique volume (affine " + affine.str() + ") would be resampled onto an axis-aligned grid of " + grid_text + " voxels at " +
                affine_number(step) + " mm, " + affine_number(bytes / (1u << 30)) + " GiB (at most " +
                std::to_string(kMaxResampledBytes >> 30) + " GiB)");
  file_grid.recompute_range();  // the background, and NaN voxels rejected before they spread
  const float background = file_grid.min_value();
  const Vec3 origin = to_vec3(lo);
  const std::array<std::int64_t, 3> dims{static_cast<std::int64_t>(extent[0]), static_cast<std::int64_t>(extent[1]),
                                         static_cast<std::int64_t>(extent[2])};
  Volume out(file_grid.type(), {static_cast<int>(dims[0]), static_cast<int>(dims[1]), static_cast<int>(dims[2])},
             Vec3{1, 1, 1} * static_cast<float>(step), origin, VoxelFill::Uninitialized);
  const auto inv = inverse(affine);
  const Vec3d limit{fd[0] - 1.0, fd[1] - 1.0, fd[2] - 1.0};
  constexpr double kEdge = 1e-3;  // voxels this close outside the grid (in voxels) take its border
  file_grid.with_voxel_type([&](auto t) {
    using T = decltype(t);
    T* dst = out.data_as<T>();
    parallel_for(static_cast<std::size_t>(dims[2]), [&](std::size_t z0, std::size_t z1) {
      for (auto z = static_cast<std::int64_t>(z0); z < static_cast<std::int64_t>(z1); ++z)
        for (std::int64_t y = 0; y < dims[1]; ++y)
          for (std::int64_t x = 0; x < dims[0]; ++x) {
            const Vec3d rel{lo[0] + static_cast<double>(x) * step - affine.offset[0], lo[1] + static_cast<double>(y) * step - affine.offset[1],
                            lo[2] + static_cast<double>(z) * step - affine.offset[2]};
            Vec3d v{};
            bool inside = true;
            for (int a = 0; a < 3; ++a) {
              v[a] = inv[a][0] * rel[0] + inv[a][1] * rel[1] + inv[a][2] * rel[2];
              inside = inside && v[a] >= -kEdge && v[a] <= limit[a] + kEdge;
            }
            float value = inside ? file_grid.sample_voxel(to_vec3(v)) : background;
            if constexpr (!std::is_same_v<T, float>) value = std::round(value);
            dst[(z * dims[1] + y) * dims[0] + x] = static_cast<T>(value);
          }
    });
  });
  if (info.orientation.empty()) info.orientation = "oblique: resampled onto LPS axes";
  info.notes.push_back("oblique affine " + affine.str() + " (axes up to " + affine_number(largest_tilt(affine)) +
                       " degrees off the world axes): resampled trilinearly onto an axis-aligned grid of " + grid_text + " voxels at " +
                       affine_number(step) + " mm (the file's grid is " + std::to_string(fd[0]) + "x" + std::to_string(fd[1]) + "x" +
                       std::to_string(fd[2]) + ")");
  return out;
}

}  // namespace

Affine Affine::diagonal(const std::array<double, 3>& steps, const std::array<double, 3>& origin) {
  Affine a;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) a.linear[r][c] = r == c ? steps[r] : 0.0;
  a.offset = origin;
  return a;
}

std::array<double, 3> Affine::apply(const std::array<double, 3>& index) const {
  std::array<double, 3> w = offset;
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) w[r] += linear[r][c] * index[c];
  return w;
}

std::string Affine::str() const {
  std::string s = "[";
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) s += affine_number(linear[r][c]) + " ";
    s += affine_number(offset[r]) + (r < 2 ? "; " : "]");
  }
  return s;
}

std::optional<AxisPermutation> axis_permutation(const Affine& affine) {
  check_affine(affine);
  AxisPermutation p;
  std::array<bool, 3> taken{};
  for (int c = 0; c < 3; ++c) {
    const Vec3d col = affine.column(c);
    const double n = norm(col);
    int along = -1;
    for (int w = 0; w < 3; ++w) {
      if (std::abs(col[w]) / n > kAxisCosineTolerance) {
        if (along >= 0) return std::nullopt;  // two world axes: oblique
        along = w;
      }
    }
    if (along < 0 || taken[along]) return std::nullopt;
    taken[along] = true;
    p.file_axis[along] = c;
    p.reversed[along] = col[along] < 0;
  }
  return p;
}

std::array<int, 3> placed_dims(const std::array<int, 3>& file_dims, const AxisPermutation& p) {
  return {file_dims[p.file_axis[0]], file_dims[p.file_axis[1]], file_dims[p.file_axis[2]]};
}

Vec3 placed_origin(const Affine& affine, const std::array<int, 3>& file_dims, const AxisPermutation& p) {
  Vec3d first{0, 0, 0};  // the file voxel that becomes the stored grid's first
  for (int w = 0; w < 3; ++w)
    if (p.reversed[w]) first[p.file_axis[w]] = file_dims[p.file_axis[w]] - 1.0;
  const Vec3d o = affine.apply(first);
  // Each stored axis takes its own world coordinate; the others' cosines are below the tolerance.
  return to_vec3(o);
}

FileWindow file_window(const SliceChooser* choose, const std::array<int, 3>& file_dims, const std::optional<AxisPermutation>& p) {
  FileWindow w;
  w.count = file_dims[2];
  if (!choose || !p) return w;
  w.placed = checked_slices(*choose, placed_dims(file_dims, *p));
  w.in_part = p->file_axis[2] == 2 && w.placed->count < file_dims[2];
  if (w.in_part) {
    w.file_first = p->reversed[2] ? file_dims[2] - w.placed->first - w.placed->count : w.placed->first;
    w.count = w.placed->count;
  }
  return w;
}

Volume place_window(Volume file_slices, const Affine& affine, const std::array<int, 3>& file_dims, const AxisPermutation& p,
                    const FileWindow& window, VolumeFileInfo& info) {
  Affine window_affine = affine;  // the window's first file slice is its index 0
  for (int d = 0; d < 3; ++d) window_affine.offset[d] += window.file_first * affine.linear[d][2];
  Volume placed = place_volume(std::move(file_slices), window_affine, info);
  info.affine = affine;
  placed.recompute_range();  // this window's own; a distributed scene replaces it by the whole grid's
  placed.set_origin(placed_origin(affine, file_dims, p));
  placed.set_window(window.placed->first, file_dims[2]);
  return placed;
}

Volume keep_chosen_slices(Volume placed, const SliceChooser* choose, const FileWindow& window, WindowRead* read) {
  if (!choose) return placed;
  const SliceRange slices = window.placed ? *window.placed : checked_slices(*choose, placed.dims());
  if (slices.count == placed.dims()[2]) return placed;
  if (read) read->whole = true;
  return placed.window_z(slices.first, slices.count);
}

Volume place_volume(Volume file_grid, const Affine& affine, VolumeFileInfo& info) {
  info.affine = affine;
  if (const auto p = axis_permutation(affine)) return reordered(std::move(file_grid), affine, *p, info);
  return resampled(std::move(file_grid), affine, info);
}

}  // namespace penumbra
