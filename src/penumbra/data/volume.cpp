#include "penumbra/data/volume.h"

#include <cmath>
#include <cstring>
#include <limits>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"

namespace penumbra {

std::string to_string(ScalarType type) {
  switch (type) {
    case ScalarType::UInt8: return "uint8";
    case ScalarType::Int16: return "int16";
    case ScalarType::UInt16: return "uint16";
    case ScalarType::Float32: return "float32";
  }
  return "?";
}

ScalarType scalar_type_from_string(const std::string& name) {
  if (name == "uint8") return ScalarType::UInt8;
  if (name == "int16") return ScalarType::Int16;
  if (name == "uint16") return ScalarType::UInt16;
  if (name == "float32") return ScalarType::Float32;
  throw Error("unknown voxel type '" + name + "' (expected uint8, int16, uint16 or float32)");
}

std::uint64_t macrocell_held_bytes(const std::array<std::int64_t, 3>& dims) {
  std::uint64_t cells = 1;
  for (const std::int64_t d : dims) cells *= static_cast<std::uint64_t>(std::max<std::int64_t>(1, (d - 1 + 7) / 8));
  return cells * 9;
}

std::uint64_t volume_held_bytes(const std::array<std::int64_t, 3>& dims, ScalarType type) {
  return static_cast<std::uint64_t>(dims[0]) * static_cast<std::uint64_t>(dims[1]) * static_cast<std::uint64_t>(dims[2]) * scalar_size(type) +
         macrocell_held_bytes(dims);
}

std::size_t scalar_size(ScalarType type) {
  switch (type) {
    case ScalarType::UInt8: return 1;
    case ScalarType::Int16:
    case ScalarType::UInt16: return 2;
    case ScalarType::Float32: return 4;
  }
  return 0;
}

std::size_t checked_voxel_count(const std::array<std::int64_t, 3>& dims) {
  std::uint64_t count = 1;
  for (int a = 0; a < 3; ++a) {
    if (dims[a] <= 0)
      throw Error("dimension " + std::to_string(a) + " is " + std::to_string(dims[a]) + " (expected a positive size)");
    if (static_cast<std::uint64_t>(dims[a]) > kMaxVoxels || count > kMaxVoxels / static_cast<std::uint64_t>(dims[a]))
      throw Error("dimensions " + std::to_string(dims[0]) + "x" + std::to_string(dims[1]) + "x" +
                  std::to_string(dims[2]) + " are absurd (more than 2^34 voxels)");
    count *= static_cast<std::uint64_t>(dims[a]);
  }
  return static_cast<std::size_t>(count);
}

Volume::Volume(ScalarType type, std::array<int, 3> dims, Vec3 spacing, Vec3 origin, VoxelFill fill)
    : type_(type), dims_(dims), origin_(origin), grid_origin_z_(origin.z) {
  const std::size_t count = checked_voxel_count({dims[0], dims[1], dims[2]});
  set_spacing(spacing);
  if (!is_finite(origin)) throw Error("origin is not finite");
  owned_.resize(count * scalar_size(type));
  data_ = owned_.data();
  if (fill == VoxelFill::Zero)  // in parallel: zeroing is page faults first of all
    parallel_for(owned_.size(), [&](std::size_t b, std::size_t e) { std::memset(data_ + b, 0, e - b); }, 1 << 20);
}

Volume Volume::view(ScalarType type, std::array<int, 3> dims, const std::byte* voxels, std::shared_ptr<const void> owner,
                    Vec3 spacing, Vec3 origin) {
  if (!voxels || !owner) throw Error("a viewed volume needs its voxels and their owner");
  (void)checked_voxel_count({dims[0], dims[1], dims[2]});
  Volume v;
  v.type_ = type;
  v.dims_ = dims;
  v.set_spacing(spacing);
  if (!is_finite(origin)) throw Error("origin is not finite");
  v.set_origin(origin);
  v.owner_ = std::move(owner);
  v.data_ = const_cast<std::byte*>(voxels);  // never written: a view is read by the renderer only
  v.recompute_range();
  return v;
}

Volume Volume::bricked(std::array<int, 3> dims, Vec3 spacing, Vec3 origin,
                       const std::function<std::optional<float>(const std::array<int, 3>&)>& shared_value,
                       const std::function<void(const std::array<int, 3>&, float*)>& fill) {
  (void)checked_voxel_count({dims[0], dims[1], dims[2]});
  Volume v;
  v.type_ = ScalarType::Float32;
  v.dims_ = dims;
  v.set_spacing(spacing);
  if (!is_finite(origin)) throw Error("origin is not finite");
  v.set_origin(origin);
  v.brick_grid_ = bricks(dims);
  const auto& g = v.brick_grid_;
  const std::size_t count = static_cast<std::size_t>(g[0]) * g[1] * g[2];
  // Shared bricks first (one per distinct value), then the stored ones in brick order.
  constexpr std::size_t kUnset = ~std::size_t{0};
  v.brick_base_.assign(count, kUnset);
  std::vector<float> shared;
  std::vector<std::size_t> stored;
  for (int bz = 0, n = 0; bz < g[2]; ++bz)
    for (int by = 0; by < g[1]; ++by)
      for (int bx = 0; bx < g[0]; ++bx, ++n) {
        const auto value = shared_value({bx, by, bz});
        if (!value) {
          stored.push_back(static_cast<std::size_t>(n));
          continue;
        }
        std::size_t s = 0;
        while (s < shared.size() && !(shared[s] == *value)) ++s;  // a handful of values: background, inside
        if (s == shared.size()) {
          if (shared.size() == 256) throw Error("more than 256 distinct constant bricks (expected sparse data)");
          shared.push_back(*value);
        }
        v.brick_base_[static_cast<std::size_t>(n)] = s * kBrickVoxels;
      }
  v.shared_end_ = shared.size() * kBrickVoxels;
  v.stored_ = v.shared_end_ + stored.size() * kBrickVoxels;
  (void)checked_voxel_count({static_cast<std::int64_t>(v.stored_), 1, 1});
  v.owned_.resize(v.stored_ * sizeof(float));
  v.data_ = v.owned_.data();
  float* out = v.data_as<float>();
  for (std::size_t s = 0; s < shared.size(); ++s) std::fill(out + s * kBrickVoxels, out + (s + 1) * kBrickVoxels, shared[s]);
  for (std::size_t s = 0; s < stored.size(); ++s) v.brick_base_[stored[s]] = v.shared_end_ + s * kBrickVoxels;
  parallel_for(stored.size(), [&](std::size_t b, std::size_t e) {
    for (std::size_t s = b; s < e; ++s) {
      const std::size_t n = stored[s];
      const std::array<int, 3> brick{static_cast<int>(n % static_cast<std::size_t>(g[0])),
                                     static_cast<int>(n / static_cast<std::size_t>(g[0]) % static_cast<std::size_t>(g[1])),
                                     static_cast<int>(n / (static_cast<std::size_t>(g[0]) * g[1]))};
      fill(brick, out + v.shared_end_ + s * kBrickVoxels);
    }
  }, 16);
  v.recompute_range();
  return v;
}

Volume Volume::densified(std::size_t max_bytes) const {
  if (!is_bricked()) return *this;
  if (voxel_count() > max_bytes / scalar_size(type_))
    throw Error("the dense copy of this sparse volume (" + std::to_string(dims_[0]) + "x" + std::to_string(dims_[1]) + "x" +
                std::to_string(dims_[2]) + " voxels) would take " + std::to_string(voxel_count() * scalar_size(type_) >> 20) +
                " MiB, more than the " + std::to_string(max_bytes >> 20) + " MiB allowed");
  Volume dense(type_, dims_, spacing_, origin_, VoxelFill::Uninitialized);
  parallel_for(static_cast<std::size_t>(dims_[2]), [&](std::size_t k0, std::size_t k1) {
    for (int k = static_cast<int>(k0); k < static_cast<int>(k1); ++k)
      for (int j = 0; j < dims_[1]; ++j)
        for (int i = 0; i < dims_[0]; ++i) dense.set_value(dense.index(i, j, k), value(i, j, k));
  });
  dense.range_ = range_;
  dense.level_set_ = level_set_;
  dense.opacity_length_ = opacity_length_;
  return dense;
}

Volume::Volume(const Volume& o)
    : type_(o.type_), dims_(o.dims_), spacing_(o.spacing_), inv_spacing_(o.inv_spacing_), origin_(o.origin_),
      owned_(o.owned_), owner_(o.owner_), data_(o.owner_ ? o.data_ : owned_.data()), range_(o.range_),
      brick_base_(o.brick_base_), brick_grid_(o.brick_grid_), stored_(o.stored_), shared_end_(o.shared_end_),
      level_set_(o.level_set_), opacity_length_(o.opacity_length_), window_first_(o.window_first_), whole_slices_(o.whole_slices_),
      window_offset_(o.window_offset_), grid_origin_z_(o.grid_origin_z_) {}

Volume::Volume(Volume&& o) noexcept
    : type_(o.type_), dims_(o.dims_), spacing_(o.spacing_), inv_spacing_(o.inv_spacing_), origin_(o.origin_),
      owned_(std::move(o.owned_)), owner_(std::move(o.owner_)), data_(o.data_), range_(o.range_),
      brick_base_(std::move(o.brick_base_)), brick_grid_(o.brick_grid_), stored_(o.stored_), shared_end_(o.shared_end_),
      level_set_(o.level_set_), opacity_length_(o.opacity_length_), window_first_(o.window_first_), whole_slices_(o.whole_slices_),
      window_offset_(o.window_offset_), grid_origin_z_(o.grid_origin_z_) {
  o.data_ = nullptr;
  o.dims_ = {0, 0, 0};
  o.brick_base_.clear();
}

Volume& Volume::operator=(const Volume& o) {
  if (this != &o) *this = Volume(o);
  return *this;
}

Volume& Volume::operator=(Volume&& o) noexcept {
  type_ = o.type_;
  dims_ = o.dims_;
  spacing_ = o.spacing_;
  inv_spacing_ = o.inv_spacing_;
  origin_ = o.origin_;
  owned_ = std::move(o.owned_);
  owner_ = std::move(o.owner_);
  data_ = o.data_;
  range_ = o.range_;
  brick_base_ = std::move(o.brick_base_);
  brick_grid_ = o.brick_grid_;
  stored_ = o.stored_;
  shared_end_ = o.shared_end_;
  level_set_ = o.level_set_;
  opacity_length_ = o.opacity_length_;
  window_first_ = o.window_first_;
  whole_slices_ = o.whole_slices_;
  window_offset_ = o.window_offset_;
  grid_origin_z_ = o.grid_origin_z_;
  o.data_ = nullptr;
  o.dims_ = {0, 0, 0};
  o.brick_base_.clear();
  return *this;
}

void Volume::set_spacing(const Vec3& spacing) {
  for (int a = 0; a < 3; ++a)
    if (!(spacing[a] > 0) || !std::isfinite(spacing[a]))
      throw Error("spacing " + std::to_string(spacing[a]) + " on axis " + std::to_string(a) + " (expected a positive number)");
  spacing_ = spacing;
  if (is_window()) origin_.z = grid_origin_z_ + window_offset_ * spacing.z;  // it keeps the whole grid's origin
  inv_spacing_ = {1.0f / spacing.x, 1.0f / spacing.y, 1.0f / spacing.z};
}

Volume Volume::window_z(int first, int count) const {
  if (is_bricked()) throw Error("a window of a bricked (sparse) volume is not supported");
  if (first < 0 || count < 1 || first > dims_[2] - count)
    throw Error("slices " + std::to_string(first) + " to " + std::to_string(first + count - 1) + " of a volume of " +
                std::to_string(dims_[2]) + " slices");
  Volume w(type_, {dims_[0], dims_[1], count}, spacing_, origin_, VoxelFill::Uninitialized);
  const std::size_t slice = static_cast<std::size_t>(dims_[0]) * static_cast<std::size_t>(dims_[1]) * scalar_size(type_);
  std::memcpy(w.data(), data_ + static_cast<std::size_t>(first) * slice, static_cast<std::size_t>(count) * slice);
  w.range_ = range_;
  w.level_set_ = level_set_;
  w.opacity_length_ = opacity_length_;
  w.window_first_ = window_first_ + first;
  w.whole_slices_ = whole_dims()[2];
  w.window_offset_ = static_cast<float>(w.window_first_);
  w.grid_origin_z_ = grid_origin_z_;
  w.origin_.z = grid_origin_z_ + w.window_offset_ * spacing_.z;
  return w;
}

void Volume::set_window(int first, int whole_slices) {
  if (is_bricked() || is_window() || first < 0 || whole_slices < first + dims_[2])
    throw Error("slices " + std::to_string(first) + " to " + std::to_string(first + dims_[2] - 1) + " are not a window of " +
                std::to_string(whole_slices) + " slices");
  window_first_ = first;
  whole_slices_ = whole_slices;
  window_offset_ = static_cast<float>(first);
  origin_.z = grid_origin_z_ + window_offset_ * spacing_.z;
}

void Volume::set_value_range(float lo, float hi) {
  if (!std::isfinite(lo) || !std::isfinite(hi) || lo > hi)
    throw Error("value range " + std::to_string(lo) + " to " + std::to_string(hi) + " (expected finite lo <= hi)");
  range_ = {lo, hi};
}

Box3 Volume::bounds() const {
  const std::array<int, 3> d = whole_dims();
  const Vec3 o{origin_.x, origin_.y, grid_origin_z_};
  Box3 b;
  b.extend(o);
  b.extend(o + Vec3{static_cast<float>(d[0] - 1) * spacing_.x, static_cast<float>(d[1] - 1) * spacing_.y,
                    static_cast<float>(d[2] - 1) * spacing_.z});
  return b;
}

void Volume::set_value(std::size_t idx, float v) {
  switch (type_) {
    case ScalarType::UInt8: data_as<std::uint8_t>()[idx] = static_cast<std::uint8_t>(std::lround(clamp(v, 0, 255))); break;
    case ScalarType::Int16: data_as<std::int16_t>()[idx] = static_cast<std::int16_t>(std::lround(clamp(v, -32768, 32767))); break;
    case ScalarType::UInt16: data_as<std::uint16_t>()[idx] = static_cast<std::uint16_t>(std::lround(clamp(v, 0, 65535))); break;
    case ScalarType::Float32: data_as<float>()[idx] = v; break;
  }
}

void Volume::move_voxels(const std::array<int, 3>& dims, const std::array<std::int64_t, 3>& by) {
  if (is_bricked() || is_view()) throw Error("moving the voxels of a bricked or viewed volume");
  const std::size_t count = checked_voxel_count({dims[0], dims[1], dims[2]});
  if (count > voxel_count()) {  // grown first: the rows move within the larger storage
    owned_.resize(count * scalar_size(type_));
    data_ = owned_.data();
  }
  const std::array<std::int64_t, 3> old{dims_[0], dims_[1], dims_[2]}, now{dims[0], dims[1], dims[2]};
  std::array<std::int64_t, 3> lo{}, hi{};  // the voxels both grids hold, in the new grid's indices
  for (std::size_t a = 0; a < 3; ++a) {
    lo[a] = std::max<std::int64_t>(0, -by[a]);
    hi[a] = std::min(now[a], old[a] - by[a]);
  }
  if (lo[0] < hi[0] && lo[1] < hi[1] && lo[2] < hi[2]) {
    // Rows of both grids lie in increasing order, so a row moved towards the front never overwrites a row
    // still to move after it, nor one moved towards the back before it (and the reverse): the rows moving
    // to the front go first to last, those moving to the back last to first.
    const std::size_t size = scalar_size(type_);
    const auto row_bytes = static_cast<std::size_t>(hi[0] - lo[0]) * size;
    const std::int64_t rows_y = hi[1] - lo[1], rows = (hi[2] - lo[2]) * rows_y;
    auto from = [&](std::int64_t r) {
      const std::int64_t z = lo[2] + r / rows_y, y = lo[1] + r % rows_y;
      return static_cast<std::size_t>(((z + by[2]) * old[1] + (y + by[1])) * old[0] + lo[0] + by[0]) * size;
    };
    auto to = [&](std::int64_t r) {
      const std::int64_t z = lo[2] + r / rows_y, y = lo[1] + r % rows_y;
      return static_cast<std::size_t>((z * now[1] + y) * now[0] + lo[0]) * size;
    };
    for (std::int64_t r = 0; r < rows; ++r)
      if (to(r) < from(r)) std::memmove(data_ + to(r), data_ + from(r), row_bytes);
    for (std::int64_t r = rows; r-- > 0;)
      if (to(r) > from(r)) std::memmove(data_ + to(r), data_ + from(r), row_bytes);
  }
  dims_ = dims;
  owned_.resize(count * scalar_size(type_));  // (shrunk last: the pages past the new grid go back)
  data_ = owned_.data();
}

float Volume::sample_cell(const TrilinearCell& c) const {
  return with_voxel_type([&](auto type) { return sample_cell_as<decltype(type)>(c); });
}

float Volume::sample_voxel(const Vec3& v) const { return sample_cell(trilinear_cell(v)); }

Vec3 Volume::gradient(const Vec3& p) const {
  const Vec3 v = to_voxel(p);
  const float gx = sample_voxel({v.x + 1, v.y, v.z}) - sample_voxel({v.x - 1, v.y, v.z});
  const float gy = sample_voxel({v.x, v.y + 1, v.z}) - sample_voxel({v.x, v.y - 1, v.z});
  const float gz = sample_voxel({v.x, v.y, v.z + 1}) - sample_voxel({v.x, v.y, v.z - 1});
  return {gx * 0.5f * inv_spacing_.x, gy * 0.5f * inv_spacing_.y, gz * 0.5f * inv_spacing_.z};
}

namespace {

// Smallest and largest voxel of [begin, end) and the first non-finite one (or `end`).
struct RangeScan {
  float lo = std::numeric_limits<float>::max(), hi = std::numeric_limits<float>::lowest();
  std::size_t bad;
};

template <class T>
RangeScan scan_range(const T* data, std::size_t begin, std::size_t end) {
  RangeScan r{.bad = end};
  T lo = std::numeric_limits<T>::max(), hi = std::numeric_limits<T>::lowest();
  for (std::size_t i = begin; i < end; ++i) {
    if constexpr (std::is_floating_point_v<T>) {
      if (!std::isfinite(data[i])) {
        r.bad = i;
        break;
      }
    }
    lo = std::min(lo, data[i]);
    hi = std::max(hi, data[i]);
  }
  r.lo = static_cast<float>(lo);
  r.hi = static_cast<float>(hi);
  return r;
}

}  // namespace

void Volume::recompute_range() {
  const std::size_t n = stored_voxel_count();  // a bricked volume stores only voxels of its grid
  constexpr std::size_t kChunk = 1 << 22;
  std::vector<RangeScan> parts((n + kChunk - 1) / kChunk);
  parallel_for(parts.size(), [&](std::size_t b, std::size_t e) {
    for (std::size_t c = b; c < e; ++c) {
      const std::size_t begin = c * kChunk, end = std::min(n, begin + kChunk);
      switch (type_) {
        case ScalarType::UInt8: parts[c] = scan_range(data_as<std::uint8_t>(), begin, end); break;
        case ScalarType::Int16: parts[c] = scan_range(data_as<std::int16_t>(), begin, end); break;
        case ScalarType::UInt16: parts[c] = scan_range(data_as<std::uint16_t>(), begin, end); break;
        case ScalarType::Float32: parts[c] = scan_range(data_as<float>(), begin, end); break;
      }
    }
  });
  float lo = std::numeric_limits<float>::max(), hi = std::numeric_limits<float>::lowest();
  for (std::size_t c = 0; c < parts.size(); ++c) {
    const std::size_t end = std::min(n, (c + 1) * kChunk);
    if (parts[c].bad < end) {  // the first non-finite voxel, whatever the thread count
      const float v = value(parts[c].bad);
      throw Error("voxel " + std::to_string(parts[c].bad) + " is " + (std::isnan(v) ? "NaN" : "infinite") +
                  " (expected finite values)");
    }
    lo = std::min(lo, parts[c].lo);
    hi = std::max(hi, parts[c].hi);
  }
  range_ = {n ? lo : 0.0f, n ? hi : 0.0f};
}

}  // namespace penumbra
