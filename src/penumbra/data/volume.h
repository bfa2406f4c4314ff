// A scalar volume on a regular grid: voxels of uint8, int16, uint16 or float32 kept in their own type
// (a CT stays 2 bytes a voxel), with dimensions, spacing and origin. World position of voxel (i, j, k)
// is origin + (i, j, k) * spacing; the volume's box spans the voxel centres.
//
// Two layouts of the same grid:
// - dense: x fastest, index(i, j, k) = (k·ny + j)·nx + i;
// - bricked (sparse data such as an OpenVDB grid, see Volume::bricked): the grid cut into bricks of
//   8³ cells, each stored as its 9³ voxels (the face shared with the next brick is stored in both), so
//   that the 8 corners of every trilinear cell lie in one brick at the fixed strides (1, 9, 81). A
//   brick whose voxels, and the voxels one beyond them that central differences reach, all hold one
//   value is not stored: it points at one shared brick of that value. A mostly empty box then costs
//   memory for its occupied bricks only.
// Code that reads a cell's corners takes index(i, j, k) of its lower corner and adds strides(); code
// that walks every voxel uses for_each_value() or value(i, j, k); data() is the storage of either
// layout, and only dense code may walk it as rows.
//
// A window (one rank's brick, data/io/volume_io.h load_volume_window): slices [window_first(),
// window_first() + dims()[2]) of a dense grid of whole_dims(). Its voxels, dims(), origin() (its first
// voxel), index() and sampling are the window's own; bounds() is the whole grid's box and the value range
// is the whole grid's (set_value_range), so that everything fitted to the data — light frustums, the
// ray lattices cut by the box, transfer functions, gradient weights — is the same on every rank.
#pragma once

#include <algorithm>
#include <array>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/data/voxel_bytes.h"

namespace penumbra {

enum class ScalarType { UInt8, Int16, UInt16, Float32 };

std::string to_string(ScalarType type);
ScalarType scalar_type_from_string(const std::string& name);  // "uint8", "int16", "uint16", "float32"
std::size_t scalar_size(ScalarType type);

// Calls f(T{}) with the C++ type of a voxel of this type: the one switch a typed loop needs.
template <class F> decltype(auto) with_scalar_type(ScalarType type, F&& f) {
  switch (type) {
    case ScalarType::UInt8: return f(std::uint8_t{});
    case ScalarType::Int16: return f(std::int16_t{});
    case ScalarType::UInt16: return f(std::uint16_t{});
    case ScalarType::Float32: break;
  }
  return f(float{});
}

// Largest voxel count a volume may have (2^34 voxels); larger products are taken as lying headers.
constexpr std::uint64_t kMaxVoxels = 1ull << 34;

// Checks dims > 0 and that their product (times the voxel size) neither overflows nor exceeds kMaxVoxels.
std::size_t checked_voxel_count(const std::array<std::int64_t, 3>& dims);

// What a volume of `dims` voxels of `type` holds once rendered, gradients aside: its voxels and the
// macrocell grid and empty-cell marks beside them (9 bytes a cell of 8³ voxels, accel/macrocell_grid.h,
// whose cell count this repeats). A memory budget (the scene's memory_budget) counts these bytes, and
// kGradientBytesPerVoxel more where the shading gradients are stored (render/prepared_volume.h).
std::uint64_t macrocell_held_bytes(const std::array<std::int64_t, 3>& dims);
std::uint64_t volume_held_bytes(const std::array<std::int64_t, 3>& dims, ScalarType type);
constexpr std::uint64_t kGradientBytesPerVoxel = 4;

// The 2x2x2 voxels around continuous voxel coordinates and the weights between them: what every
// trilinear fetch on this grid (scalars, the ray caster's gradient volume) needs. Coordinates outside
// the grid are clamped to the border; a dimension of size 1 has stride 0.
struct TrilinearCell {
  std::size_t base;              // index of the lower corner voxel
  std::size_t sx, sy, sz;        // index strides to the upper neighbours
  float tx, ty, tz;              // fractional position inside the cell
  int i, j, k;                   // the lower corner voxel
};

// Zero: the voxels start at 0. Uninitialized: left as allocated, for a caller that writes every voxel
// (a loader reading the file into place, a generator): a large volume then costs one pass, not two.
enum class VoxelFill { Zero, Uninitialized };

// An allocator whose value-initialisation does nothing, so that a vector of bytes can be sized without
// being zeroed.
template <class T>
struct DefaultInitAllocator : std::allocator<T> {
  template <class U> struct rebind { using other = DefaultInitAllocator<U>; };
  DefaultInitAllocator() = default;
  template <class U> DefaultInitAllocator(const DefaultInitAllocator<U>&) noexcept {}
  template <class U> void construct(U* p) noexcept(std::is_nothrow_default_constructible_v<U>) { ::new (static_cast<void*>(p)) U; }
  template <class U, class... Args> void construct(U* p, Args&&... args) {
    ::new (static_cast<void*>(p)) U(std::forward<Args>(args)...);
  }
};

class Volume {
public:
  Volume() = default;
  // Allocates the voxels (zero-filled unless `fill` says otherwise). Throws Error on zero, negative or
  // absurd dimensions or bad spacing.
  Volume(ScalarType type, std::array<int, 3> dims, Vec3 spacing = {1, 1, 1}, Vec3 origin = {0, 0, 0},
         VoxelFill fill = VoxelFill::Zero);
  // Voxels that someone else owns (a NumPy array), viewed in place without a copy: `owner` keeps them
  // alive as long as this volume or a copy of it lives. The renderer never writes them. Checks the
  // dimensions and the voxels' range like a loaded volume (NaN or infinite voxels are an Error).
  static Volume view(ScalarType type, std::array<int, 3> dims, const std::byte* voxels, std::shared_ptr<const void> owner,
                     Vec3 spacing = {1, 1, 1}, Vec3 origin = {0, 0, 0});
  // Copies own a copy of allocated voxels and share viewed ones.
  // A bricked float32 volume (see the top of this file). `shared_value(b)` returns the value of brick b
  // (brick coordinates, each from 0 to bricks(dims) - 1) when its voxels 8b - 1 ... 8b + 9 per axis
  // (clamped to the grid) all hold that value, else nothing; `fill(b, out)` writes the 9³ voxels of a
  // stored brick, out[(l_z·9 + l_y)·9 + l_x] = voxel min(8b + l, dims - 1) per axis. `fill` is called
  // in parallel, each call for a different brick.
  static Volume bricked(std::array<int, 3> dims, Vec3 spacing, Vec3 origin,
                        const std::function<std::optional<float>(const std::array<int, 3>&)>& shared_value,
                        const std::function<void(const std::array<int, 3>&, float*)>& fill);
  static constexpr int kBrickCells = 8;
  static constexpr int kBrickSide = kBrickCells + 1;
  static constexpr std::size_t kBrickVoxels = static_cast<std::size_t>(kBrickSide) * kBrickSide * kBrickSide;
  static std::array<int, 3> bricks(const std::array<int, 3>& dims) {
    return {std::max(1, (dims[0] + kBrickCells - 2) / kBrickCells), std::max(1, (dims[1] + kBrickCells - 2) / kBrickCells),
            std::max(1, (dims[2] + kBrickCells - 2) / kBrickCells)};
  }
  // The same voxels in the dense layout (Error when that would exceed `max_bytes`).
  Volume densified(std::size_t max_bytes) const;
  // Slices [first, first + count) of this dense grid's z (this grid's own numbering) as a window of the
  // whole grid (a copy of those voxels, the range kept). Error outside the grid or on a bricked volume.
  Volume window_z(int first, int count) const;
  // Makes this dense volume, whose origin() is the whole grid's and whose voxels hold slices [first, first
  // + dims()[2]) of a grid of `whole_slices` slices, that window: its origin moves to slice `first`.
  void set_window(int first, int whole_slices);
  bool is_window() const { return whole_slices_ > 0; }
  int window_first() const { return window_first_; }
  std::array<int, 3> whole_dims() const { return {dims_[0], dims_[1], is_window() ? whole_slices_ : dims_[2]}; }

  Volume(const Volume& other);
  Volume(Volume&& other) noexcept;
  Volume& operator=(const Volume& other);
  Volume& operator=(Volume&& other) noexcept;

  ScalarType type() const { return type_; }
  const std::array<int, 3>& dims() const { return dims_; }
  const Vec3& spacing() const { return spacing_; }
  const Vec3& origin() const { return origin_; }  // the first stored voxel's position
  // The whole grid's origin (a window moves with it).
  void set_origin(const Vec3& o) {
    grid_origin_z_ = o.z;
    origin_ = o + Vec3{0, 0, static_cast<float>(window_first_) * spacing_.z};
  }
  void set_spacing(const Vec3& spacing);  // Error unless positive and finite
  // The length a transfer function's opacity refers to: the smallest voxel edge, or for a coarser level
  // of a pyramid the finest level's (set by its reader), so that a level shows the same matter per unit
  // length as the data at full resolution.
  float opacity_length() const { return opacity_length_ > 0 ? opacity_length_ : std::min(spacing_.x, std::min(spacing_.y, spacing_.z)); }
  void set_opacity_length(float length) { opacity_length_ = length; }
  std::size_t voxel_count() const { return static_cast<std::size_t>(dims_[0]) * dims_[1] * dims_[2]; }
  std::size_t memory_bytes() const {  // what this volume allocated (a view: 0)
    return owned_.size() + brick_base_.size() * sizeof(brick_base_[0]);
  }
  bool is_bricked() const { return !brick_base_.empty(); }
  // A level set (an OpenVDB grid of that class): signed distance, negative inside; its surface is the
  // isosurface at 0, which the automatic scene shows.
  bool level_set() const { return level_set_; }
  void set_level_set(bool level_set) { level_set_ = level_set; }
  // Voxels stored: voxel_count() when dense; stored bricks × 9³ when bricked.
  std::size_t stored_voxel_count() const { return is_bricked() ? stored_ : voxel_count(); }
  // Bricked only: the bricks per axis, where brick b's 9³ voxels start in data(), and whether it is one
  // of the shared single-valued bricks.
  const std::array<int, 3>& brick_grid() const { return brick_grid_; }
  std::size_t brick_base(int bx, int by, int bz) const {
    return brick_base_[(static_cast<std::size_t>(bz) * brick_grid_[1] + by) * brick_grid_[0] + bx];
  }
  bool brick_is_shared(int bx, int by, int bz) const { return brick_base(bx, by, bz) < shared_end_; }
  bool is_view() const { return static_cast<bool>(owner_); }
  Box3 bounds() const;  // world box through the first and last voxel centres (of the whole grid, for a window)

  // Storage in the volume's own type (its layout: see the top of this file).
  std::byte* data() { return data_; }
  const std::byte* data() const { return data_; }
  template <class T> T* data_as() { return reinterpret_cast<T*>(data_); }
  template <class T> const T* data_as() const { return reinterpret_cast<const T*>(data_); }

  // Where voxel (i, j, k) is stored; when it is the lower corner of a cell, the other corners are at
  // + strides().
  std::size_t index(int i, int j, int k) const {
    if (brick_base_.empty()) return (static_cast<std::size_t>(k) * dims_[1] + j) * dims_[0] + i;
    const int bx = std::min(i / kBrickCells, brick_grid_[0] - 1), by = std::min(j / kBrickCells, brick_grid_[1] - 1),
              bz = std::min(k / kBrickCells, brick_grid_[2] - 1);
    return brick_base(bx, by, bz) +
           (static_cast<std::size_t>(k - bz * kBrickCells) * kBrickSide + static_cast<std::size_t>(j - by * kBrickCells)) *
               kBrickSide +
           static_cast<std::size_t>(i - bx * kBrickCells);
  }
  // Index steps to the +x, +y and +z neighbours of a cell's lower corner (0 along an axis of size 1).
  std::array<std::size_t, 3> strides() const {
    const bool b = is_bricked();
    return {dims_[0] > 1 ? std::size_t{1} : 0,
            dims_[1] > 1 ? (b ? std::size_t{kBrickSide} : static_cast<std::size_t>(dims_[0])) : 0,
            dims_[2] > 1 ? (b ? std::size_t{kBrickSide} * kBrickSide : static_cast<std::size_t>(dims_[0]) * dims_[1]) : 0};
  }
  float value(std::size_t idx) const {
    switch (type_) {
      case ScalarType::UInt8: return data_as<std::uint8_t>()[idx];
      case ScalarType::Int16: return data_as<std::int16_t>()[idx];
      case ScalarType::UInt16: return data_as<std::uint16_t>()[idx];
      case ScalarType::Float32: return data_as<float>()[idx];
    }
    return 0;
  }
  float value(int i, int j, int k) const { return value(index(i, j, k)); }
  void set_value(std::size_t idx, float v);  // dense volumes (a bricked voxel may be stored twice)
  // Dense volumes that own their voxels: becomes a grid of `dims` whose voxel v holds the value of the
  // old voxel v + by where that lies in the old grid (the others are left undefined), in place: the
  // storage grows or shrinks to the new grid (VoxelBytes: pages remapped, not copied) and each row of
  // voxels both grids hold is moved once, no second grid allocated. What a box of a level that moves keeps
  // of itself (render/view_refinement.h). Error for a bricked or viewed volume.
  void move_voxels(const std::array<int, 3>& dims, const std::array<std::int64_t, 3>& by);

  // Continuous voxel coordinates of a world point.
  // A window's z is the whole grid's less its first slice (exact for its samples: both are integers'
  // worth apart), so that its samples interpolate with the same weights as the whole grid's.
  Vec3 to_voxel(const Vec3& p) const {
    return {(p.x - origin_.x) * inv_spacing_.x, (p.y - origin_.y) * inv_spacing_.y,
            (p.z - grid_origin_z_) * inv_spacing_.z - window_offset_};
  }
  // Trilinear interpolation at a world point; positions outside are clamped to the border voxels.
  float sample(const Vec3& p) const { return sample_voxel(to_voxel(p)); }
  float sample_voxel(const Vec3& v) const;
  [[gnu::always_inline]] TrilinearCell trilinear_cell(const Vec3& v) const {  // (inlined: once per volume sample)
    const float fx = clamp(v.x, 0.0f, static_cast<float>(dims_[0] - 1));
    const float fy = clamp(v.y, 0.0f, static_cast<float>(dims_[1] - 1));
    const float fz = clamp(v.z, 0.0f, static_cast<float>(dims_[2] - 1));
    const int i = std::min(static_cast<int>(fx), std::max(dims_[0] - 2, 0));
    const int j = std::min(static_cast<int>(fy), std::max(dims_[1] - 2, 0));
    const int k = std::min(static_cast<int>(fz), std::max(dims_[2] - 2, 0));
    const auto s = strides();
    return {index(i, j, k), s[0], s[1], s[2], fx - static_cast<float>(i), fy - static_cast<float>(j), fz - static_cast<float>(k),
            i, j, k};
  }
  float sample_cell(const TrilinearCell& c) const;  // the interpolant in a cell found before
  // The same for a caller that knows the voxel type (T must be the volume's: see with_voxel_type), so
  // that a loop over many samples decides the type once rather than per sample.
  template <class T> float sample_cell_as(const TrilinearCell& c) const {
    const T* d = data_as<T>();
    const std::size_t b = c.base;
    const float c000 = static_cast<float>(d[b]), c100 = static_cast<float>(d[b + c.sx]);
    const float c010 = static_cast<float>(d[b + c.sy]), c110 = static_cast<float>(d[b + c.sy + c.sx]);
    const float c001 = static_cast<float>(d[b + c.sz]), c101 = static_cast<float>(d[b + c.sz + c.sx]);
    const float c011 = static_cast<float>(d[b + c.sz + c.sy]), c111 = static_cast<float>(d[b + c.sz + c.sy + c.sx]);
    const float c00 = c000 + (c100 - c000) * c.tx, c10 = c010 + (c110 - c010) * c.tx;
    const float c01 = c001 + (c101 - c001) * c.tx, c11 = c011 + (c111 - c011) * c.tx;
    const float c0 = c00 + (c10 - c00) * c.ty, c1 = c01 + (c11 - c01) * c.ty;
    return c0 + (c1 - c0) * c.tz;
  }
  // Calls f(T{}) with the voxels' C++ type (see with_scalar_type).
  template <class F> decltype(auto) with_voxel_type(F&& f) const { return with_scalar_type(type_, std::forward<F>(f)); }
  // Calls f(value, count) for every voxel of the grid, runs of equal voxels at once (a shared brick's
  // voxels in one call), in no particular order.
  template <class F> void for_each_value(F&& f) const {
    if (!is_bricked()) {
      for (std::size_t i = 0, n = voxel_count(); i < n; ++i) f(value(i), std::size_t{1});
      return;
    }
    for_each_brick_value(f);
  }

  // World-space gradient by central differences of the trilinear interpolant, one voxel apart per axis.
  Vec3 gradient(const Vec3& p) const;

  // Smallest and largest voxel value (computed once, on first call or after recompute_range()).
  float min_value() const { return range_[0]; }
  float max_value() const { return range_[1]; }
  void recompute_range();  // also rejects NaN or infinite voxels with an Error (in parallel)
  // A window: the whole grid's range, found across the ranks (Error unless lo <= hi, both finite).
  void set_value_range(float lo, float hi);

private:
  // Bricked: each brick's voxels that no lower brick owns (local 0..7, and 8 on the grid's last voxel).
  template <class F> void for_each_brick_value(F& f) const {
    for (int bz = 0; bz < brick_grid_[2]; ++bz)
      for (int by = 0; by < brick_grid_[1]; ++by)
        for (int bx = 0; bx < brick_grid_[0]; ++bx) {
          const int b[3] = {bx, by, bz};
          int n[3];
          for (int a = 0; a < 3; ++a)
            n[a] = std::min(dims_[a], (b[a] + 1) * kBrickCells + (b[a] + 1 == brick_grid_[a] ? 1 : 0)) - b[a] * kBrickCells;
          const std::size_t base = brick_base(bx, by, bz);
          if (base < shared_end_) {
            f(value(base), static_cast<std::size_t>(n[0]) * n[1] * n[2]);
            continue;
          }
          for (int z = 0; z < n[2]; ++z)
            for (int y = 0; y < n[1]; ++y)
              for (int x = 0; x < n[0]; ++x)
                f(value(base + (static_cast<std::size_t>(z) * kBrickSide + y) * kBrickSide + x), std::size_t{1});
        }
  }

  ScalarType type_ = ScalarType::Float32;
  std::array<int, 3> dims_{0, 0, 0};
  Vec3 spacing_{1, 1, 1}, inv_spacing_{1, 1, 1}, origin_{0, 0, 0};
  VoxelBytes owned_;                                                // allocated voxels, or empty for a view
  std::shared_ptr<const void> owner_;                               // a view's voxels stay alive through this
  std::byte* data_ = nullptr;                                       // owned_.data() or the viewed voxels
  std::array<float, 2> range_{0, 0};
  // Bricked layout only (empty when dense): the first voxel of each brick in data(), the number of
  // stored voxels, and where the shared single-valued bricks (stored first) end.
  std::vector<std::size_t> brick_base_;
  std::array<int, 3> brick_grid_{0, 0, 0};
  std::size_t stored_ = 0, shared_end_ = 0;
  bool level_set_ = false;
  float opacity_length_ = 0;  // 0: the smallest voxel edge
  // A window: its first slice, the whole grid's slices (0: not a window), the first slice as a float,
  // and the whole grid's origin z (origin_.z otherwise).
  int window_first_ = 0, whole_slices_ = 0;
  float window_offset_ = 0, grid_origin_z_ = 0;
};

}  // namespace penumbra
