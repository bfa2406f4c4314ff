// The "ct-body" renderer (ct_body.h): every structure of ct_body_anatomy.cpp is an ellipsoid or a stack
// of elliptic cross-sections, so a z slice sees each as an ellipse. A slice is painted structure by
// structure (each in its own bounding rows and spans, with a one-voxel anti-aliased edge), then textured,
// given noise and written out. Slices run in parallel; every random number is keyed by position.
#include "penumbra/data/ct_body.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include <tbb/enumerable_thread_specific.h>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/data/ct_body_anatomy.h"

namespace penumbra {

// The types CtBodySlices::State keeps (named, not anonymous: a member of an external class).
namespace ct_body_slices {

// The slice grid and its working buffers: painted values, the low-frequency field in [-1, 1] and the
// standard normal noise of each voxel.
struct SliceGrid {
  int nx = 0, ny = 0;
  double x0 = 0, y0 = 0, sx = 1, sy = 1;
  double edge = 1;  // width of the anti-aliasing ramp: one voxel
  // Every element is written before it is read (paint_slice, low_frequency_field, write_slice), so the
  // buffers are not zeroed when made.
  using Buffer = std::vector<float, DefaultInitAllocator<float>>;
  Buffer value, field, noise;
};

// Smoothstep-weighted value noise: random values in [-1, 1] on a cubic lattice of `cell` mm.
struct NoiseOctave {
  double cell;
  float weight;
  std::uint64_t key;
};

}  // namespace ct_body_slices

namespace {

using ct_anatomy::Item;
using ct_anatomy::Knot;
using ct_body_slices::NoiseOctave;
using ct_body_slices::SliceGrid;

constexpr double kDisplace = 1.5;  // mm: the largest boundary shift by the low-frequency field
constexpr float kTexture = 0.03f;  // the largest relative change of a tissue value by that field

// The first column at or after x (`up`), or the last at or before it, clamped to the grid.
int column(const SliceGrid& s, double x, bool up) {
  const double i = std::clamp((x - s.x0) / s.sx, -1.0, static_cast<double>(s.nx));
  return up ? std::max(0, static_cast<int>(std::ceil(i))) : std::min(s.nx - 1, static_cast<int>(std::floor(i)));
}

// Half-width of the chord at dy through the ellipse (a, b) grown by m (m < 0 shrinks it); -1 if none.
double half_width(double dy, double a, double b, double m) {
  const double am = a + m, bm = b + m;
  if (am <= 0 || bm <= 0 || std::abs(dy) >= bm) return -1;
  return am * std::sqrt(1 - (dy / bm) * (dy / bm));
}

// Coverage of the point (dx, dy) from the centre of the ellipse (a, b): a ramp one voxel wide across
// the boundary, at the first-order signed distance f / |grad f| of f = (dx/a)^2 + (dy/b)^2 - 1, moved
// outwards by up to kDisplace where the low-frequency field is positive.
double coverage(double dx, double dy, double a, double b, float field, double edge) {
  const double ia = 1 / (a * a), ib = 1 / (b * b);
  const double f = dx * dx * ia + dy * dy * ib - 1;
  const double g = 2 * std::sqrt(dx * dx * ia * ia + dy * dy * ib * ib);
  const double d = f / std::max(g, 1e-12) - kDisplace * field;
  return std::clamp(0.5 - d / edge, 0.0, 1.0);
}

// Paints one cross-section over the slice: value = value + c * (item value - value), c its coverage
// times the cover in z, less the coverage of `inner` (a shell's hollow, same centre) where given.
void paint(SliceGrid& s, const Item& it, const Knot& out, const Knot* inner, double cover) {
  const double m = s.edge + kDisplace;  // no coverage beyond, full coverage within, this margin
  const double ylo = std::max(out.cy - out.b - m, it.ymin), yhi = std::min(out.cy + out.b + m, it.ymax);
  const int j0 = std::max(0, static_cast<int>(std::ceil(std::max((ylo - s.y0) / s.sy, -1.0))));
  const int j1 = std::min(s.ny - 1, static_cast<int>(std::floor(std::min((yhi - s.y0) / s.sy, 1.0 * s.ny))));
  for (int j = j0; j <= j1; ++j) {
    const double dy = s.y0 + j * s.sy - out.cy;
    const double reach = half_width(dy, out.a, out.b, m);
    if (reach < 0) continue;
    const double full = half_width(dy, out.a, out.b, -m);
    const double hollow = inner ? half_width(dy, inner->a, inner->b, -m) : -1;  // untouched within
    const double ramp_in = inner ? half_width(dy, inner->a, inner->b, m) : -1;
    const int i0 = column(s, std::max(out.cx - reach, it.xmin), true);
    const int i1 = column(s, std::min(out.cx + reach, it.xmax), false);
    float* row = s.value.data() + static_cast<std::size_t>(j) * s.nx;
    const float* field = s.field.data() + static_cast<std::size_t>(j) * s.nx;
    // Without a hollow, the span of full coverage is a plain blend (most of the painted voxels).
    const int f0 = inner ? i1 + 1 : std::max(i0, column(s, out.cx - full, true));
    const int f1 = inner ? i1 : std::min(i1, column(s, out.cx + full, false));
    const auto edge_voxel = [&](int i) {
      const double dx = s.x0 + i * s.sx - out.cx, adx = std::abs(dx);
      if (adx <= hollow) return;
      double c = adx <= full ? 1.0 : coverage(dx, dy, out.a, out.b, field[i], s.edge);
      if (adx <= ramp_in) c -= coverage(dx, dy, inner->a, inner->b, field[i], s.edge);
      c *= cover;
      if (c > 0) row[i] += static_cast<float>(c) * (it.value - row[i]);
    };
    for (int i = i0; i < std::min(f0, i1 + 1); ++i) edge_voxel(i);
    const auto c = static_cast<float>(cover);
    for (int i = f0; i <= f1; ++i) row[i] += c * (it.value - row[i]);
    for (int i = std::max(f0, f1 + 1); i <= i1; ++i) edge_voxel(i);
  }
}


// Adds the octaves of the low-frequency field at height z to s.field: per slice the lattice plane is
// interpolated in z, per row in y, so a voxel costs one interpolation in x per octave.
void low_frequency_field(SliceGrid& s, const std::vector<NoiseOctave>& octaves, double z) {
  std::fill(s.field.begin(), s.field.end(), 0.0f);
  const auto smooth = [](double t) { return static_cast<float>(t * t * (3 - 2 * t)); };
  const double base = -1000;  // below every coordinate, so lattice indices are positive
  for (const NoiseOctave& o : octaves) {
    const auto lattice = [&](double p, int& index) {
      const double f = (p - base) / o.cell;
      index = static_cast<int>(f);
      return smooth(f - index);
    };
    int ix0 = 0, iy0 = 0, iz = 0, ix1 = 0, iy1 = 0;
    lattice(s.x0, ix0);
    lattice(s.y0, iy0);
    lattice(s.x0 + (s.nx - 1) * s.sx, ix1);
    lattice(s.y0 + (s.ny - 1) * s.sy, iy1);
    const float tz = lattice(z, iz);
    const int gx = ix1 - ix0 + 2, gy = iy1 - iy0 + 2;
    std::vector<float> plane(static_cast<std::size_t>(gx) * gy), row(static_cast<std::size_t>(gx));
    for (int b = 0; b < gy; ++b)
      for (int a = 0; a < gx; ++a) {
        const auto at = [&](int k) {
          const auto column = static_cast<std::uint64_t>(ix0 + a) | static_cast<std::uint64_t>(iy0 + b) << 24;
          return 2 * uniform_float(o.key, column, static_cast<std::uint64_t>(k)) - 1;
        };
        const float below = at(iz), above = at(iz + 1);
        plane[static_cast<std::size_t>(b) * gx + a] = below + tz * (above - below);
      }
    std::vector<int> cx(static_cast<std::size_t>(s.nx));
    std::vector<float> tx(static_cast<std::size_t>(s.nx));
    for (int i = 0; i < s.nx; ++i) {
      tx[i] = lattice(s.x0 + i * s.sx, cx[i]);
      cx[i] -= ix0;
    }
    for (int j = 0; j < s.ny; ++j) {
      int cy = 0;
      const float ty = lattice(s.y0 + j * s.sy, cy);
      const float* p0 = plane.data() + static_cast<std::size_t>(cy - iy0) * gx;
      for (int a = 0; a < gx; ++a) row[a] = p0[a] + ty * (p0[a + gx] - p0[a]);
      float* out = s.field.data() + static_cast<std::size_t>(j) * s.nx;
      for (int i = 0; i < s.nx; ++i) out[i] += o.weight * (row[cx[i]] + tx[i] * (row[cx[i] + 1] - row[cx[i]]));
    }
  }
}

// Phi^-1((i + 0.5) / 65536) for every 16-bit i (Newton's method on erfc, from 0, which converges
// monotonically): 16 random bits index a standard normal sample, tails to +-4.3 sigma.
const std::vector<float>& normal_quantiles() {
  static const std::vector<float> table = [] {
    std::vector<float> t(65536);
    for (int i = 32768; i < 65536; ++i) {
      const double p = (i + 0.5) / 65536;
      double x = 0;
      for (int step = 0; step < 100; ++step) {
        const double cdf = 0.5 * std::erfc(-x / std::sqrt(2.0));
        const double dx = (cdf - p) / (std::exp(-0.5 * x * x) / std::sqrt(2 * 3.14159265358979323846));
        x -= dx;
        if (std::abs(dx) < 1e-9) break;
      }
      t[static_cast<std::size_t>(i)] = static_cast<float>(x);
      t[static_cast<std::size_t>(65535 - i)] = -static_cast<float>(x);
    }
    return t;
  }();
  return table;
}

// Texture, noise and quantisation of a painted slice into its uint16 voxels. The noise of voxel g (its
// index in the volume) is lane g % 4 of one 64-bit hash of g / 4.
void write_slice(SliceGrid& s, std::uint64_t noise_key, float sigma, std::size_t first, std::uint16_t* out) {
  const std::vector<float>& normal = normal_quantiles();
  const std::size_t n = s.value.size();
  for (std::size_t g = first & ~std::size_t{3}; g < first + n; g += 4) {
    const std::uint64_t bits = mix64(noise_key ^ (g >> 2) * 0x9e3779b97f4a7c15ULL);
    for (std::size_t lane = 0; lane < 4; ++lane)
      if (g + lane >= first && g + lane < first + n) s.noise[g + lane - first] = normal[(bits >> (16 * lane)) & 0xFFFF];
  }
  const float* value = s.value.data();
  const float* field = s.field.data();
  const float* noise = s.noise.data();
  for (std::size_t i = 0; i < n; ++i) {
    const float v = value[i] * (1 + kTexture * field[i]) + sigma * noise[i];
    out[i] = static_cast<std::uint16_t>(std::clamp(static_cast<int>(v + 0.5f), 0, 65535));  // |v| < 2^31: noise <= 10^4
  }
}

// Paints the slice at height z: air, then every structure that reaches it, in order.
void paint_slice(SliceGrid& s, const std::vector<Item>& items, const std::vector<std::uint32_t>& active, double z,
                 double slice_step) {
  std::fill(s.value.begin(), s.value.end(), ct_tissue::kAir);
  const double h = z + ct_anatomy::kLength / 2;
  for (const std::uint32_t index : active) {
    const Item& it = items[index];
    const double cover = ct_anatomy::cover(it, h, slice_step);
    Knot out{}, in{};
    if (cover <= 0 || !ct_anatomy::section(it, h, it.inset, out)) continue;
    const bool hollow = it.shell > 0 && ct_anatomy::section(it, h, it.inset + it.shell, in);
    paint(s, it, out, hollow ? &in : nullptr, cover);
  }
}

// For each slice, the indices (in painting order) of the structures that reach it.
std::vector<std::vector<std::uint32_t>> structures_by_slice(const std::vector<Item>& items, int nz, double z0,
                                                            double sz) {
  std::vector<std::vector<std::uint32_t>> active(static_cast<std::size_t>(nz));
  for (std::size_t index = 0; index < items.size(); ++index) {
    const auto [lo, hi] = ct_anatomy::height_range(items[index]);
    const double zlo = lo - ct_anatomy::kLength / 2 - sz, zhi = hi - ct_anatomy::kLength / 2 + sz;
    const int k0 = std::max(0, static_cast<int>(std::ceil((zlo - z0) / sz)));
    const int k1 = std::min(nz - 1, static_cast<int>(std::floor((zhi - z0) / sz)));
    for (int k = k0; k <= k1; ++k) active[static_cast<std::size_t>(k)].push_back(static_cast<std::uint32_t>(index));
  }
  return active;
}

}  // namespace

CtBodyGrid ct_body_grid(const CtBodyParams& params) {
  const auto [nx, ny, nz] = params.dims;
  const double sx = ct_anatomy::kFov / nx, sy = ct_anatomy::kFov / ny, sz = ct_anatomy::kLength / nz;
  return {{sx, sy, sz}, {-0.5 * (nx - 1) * sx, -0.5 * (ny - 1) * sy, -0.5 * (nz - 1) * sz}};
}

// What every slab of one volume shares: its grid, the anatomy and which structures reach each slice,
// the noise keys, and one slice's buffers per thread, kept between slabs (a fresh 4096² slice buffer
// costs a page fault every 4 KiB).
struct CtBodySlices::State {
  CtBodyParams params;
  CtBodyGrid grid;
  std::vector<Item> items;
  std::vector<std::vector<std::uint32_t>> active;
  // Two octaves (30 and 9 mm) of the low-frequency field, and the per-voxel noise, each keyed apart.
  std::vector<NoiseOctave> octaves;
  std::uint64_t noise_key;
  tbb::enumerable_thread_specific<SliceGrid> buffers;
};

CtBodySlices::CtBodySlices(const CtBodyParams& params) {
  const CtBodyGrid grid = ct_body_grid(params);
  const std::vector<Item> items = ct_anatomy::build(params.seed);
  const int width = params.dims[0], height = params.dims[1];
  const double x0 = grid.origin[0], y0 = grid.origin[1], sx = grid.spacing[0], sy = grid.spacing[1];
  const std::size_t slice_voxels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  state_.reset(new State{params,
                         grid,
                         items,
                         structures_by_slice(items, params.dims[2], grid.origin[2], grid.spacing[2]),
                         {{30, 2.0f / 3, hash_keys(params.seed, 0xF1E1D, 1)}, {9, 1.0f / 3, hash_keys(params.seed, 0xF1E1D, 2)}},
                         hash_keys(params.seed, 0x7015E),
                         tbb::enumerable_thread_specific<SliceGrid>([=] {
                           return SliceGrid{width, height, x0, y0, sx, sy, std::max(sx, sy), SliceGrid::Buffer(slice_voxels),
                                            SliceGrid::Buffer(slice_voxels), SliceGrid::Buffer(slice_voxels)};
                         })});
}

CtBodySlices::~CtBodySlices() = default;

void CtBodySlices::make(int first, int count, std::uint16_t* out) {
  State& st = *state_;
  const int nz = st.params.dims[2];
  if (first < 0 || count < 0 || first + count > nz)
    throw Error("ct-body slices " + std::to_string(first) + " + " + std::to_string(count) + " (the volume has " + std::to_string(nz) + ")");
  const double z0 = st.grid.origin[2], sz = st.grid.spacing[2];
  const std::size_t slice_voxels = static_cast<std::size_t>(st.params.dims[0]) * static_cast<std::size_t>(st.params.dims[1]);
  // 64 chunks of slices keep the threads busy to the end.
  const std::size_t grain = std::max<std::size_t>(1, static_cast<std::size_t>(count) / 64);
  parallel_for(static_cast<std::size_t>(count), [&](std::size_t k0, std::size_t k1) {
    SliceGrid& s = st.buffers.local();
    for (std::size_t k = k0 + static_cast<std::size_t>(first); k < k1 + static_cast<std::size_t>(first); ++k) {
      const double z = z0 + static_cast<double>(k) * sz;
      low_frequency_field(s, st.octaves, z);
      paint_slice(s, st.items, st.active[k], z, sz);
      write_slice(s, st.noise_key, static_cast<float>(st.params.noise), k * slice_voxels,
                  out + (k - static_cast<std::size_t>(first)) * slice_voxels);
    }
  }, grain);
}

Volume make_ct_body_volume(const CtBodyParams& params) {
  const CtBodyGrid grid = ct_body_grid(params);
  Volume volume(ScalarType::UInt16, params.dims,
                Vec3(static_cast<float>(grid.spacing[0]), static_cast<float>(grid.spacing[1]), static_cast<float>(grid.spacing[2])),
                Vec3(static_cast<float>(grid.origin[0]), static_cast<float>(grid.origin[1]), static_cast<float>(grid.origin[2])),
                VoxelFill::Uninitialized);
  CtBodySlices(params).make(0, params.dims[2], volume.data_as<std::uint16_t>());
  volume.recompute_range();
  return volume;
}

}  // namespace penumbra
