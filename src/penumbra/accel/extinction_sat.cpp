#include "penumbra/accel/extinction_sat.h"

#include <cmath>
#include <utility>

#include "penumbra/core/cutoffs.h"
#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"

namespace penumbra {
namespace {

constexpr int kTableSize = 4096;

// τ (per world unit) and τ·c of the transfer function, tabulated over the data range.
struct ExtinctionTable {
  ExtinctionTable(const TransferFunction& tf, Compositing compositing, float reference_step, float lo, float hi)
      : lo_(lo) {
    if (!(hi > lo)) hi = lo + 1.0f;
    scale_ = static_cast<float>(kTableSize - 1) / (hi - lo);
    entries_.resize(kTableSize);
    for (int i = 0; i < kTableSize; ++i) {
      const double v = static_cast<double>(lo) + (static_cast<double>(hi) - lo) * i / (kTableSize - 1);
      const Rgba e = tf.evaluate(static_cast<float>(v));
      const float tau = extinction_coefficient(e.a, compositing) / reference_step;
      entries_[static_cast<std::size_t>(i)] = {tau, tau * e.rgb.r, tau * e.rgb.g, tau * e.rgb.b};
    }
  }
  std::array<float, 4> lookup(float value) const {
    float f = (value - lo_) * scale_;
    f = f < 0 ? 0 : (f > kTableSize - 1 ? static_cast<float>(kTableSize - 1) : f);
    const int i = static_cast<int>(f);
    const int j = i + 1 < kTableSize ? i + 1 : i;
    const float t = f - static_cast<float>(i);
    const auto& a = entries_[static_cast<std::size_t>(i)];
    const auto& b = entries_[static_cast<std::size_t>(j)];
    return {a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t, a[3] + (b[3] - a[3]) * t};
  }

private:
  float lo_, scale_;
  std::vector<std::array<float, 4>> entries_;
};

}  // namespace

std::array<int, 3> sat_dims(const Vec3& extent, int resolution) {
  const float longest = std::max(extent.x, std::max(extent.y, extent.z));
  std::array<int, 3> d;
  for (int a = 0; a < 3; ++a)
    d[a] = std::max(1, static_cast<int>(std::lround(static_cast<double>(resolution) * extent[a] / longest)));
  return d;
}

ExtinctionSat::ExtinctionSat(const Volume& volume, const TransferFunction& tf, Compositing compositing,
                             float reference_step, int resolution, bool with_colour, const ParticleSet* spheres,
                             const ShadowBrick* brick, const ClipPlanes* clip, const Volume* finer, const Box3* cells_over) {
  if (resolution < kMinSatResolution || resolution > kMaxSatResolution)
    throw Error("light_cache.resolution " + std::to_string(resolution) + " (expected " +
                std::to_string(kMinSatResolution) + " to " + std::to_string(kMaxSatResolution) + ")");
  if (!(reference_step > 0)) throw Error("extinction SAT: reference step must be positive");
  if ((finer || cells_over) && brick) throw Error("extinction SAT: a finer box or other cells for a distributed brick are not supported");
  const std::array<int, 3> vd = volume.whole_dims();  // a window (one brick's voxels) is cut from the whole grid
  const Vec3& sp = volume.spacing();
  // The box through the voxel centres; an axis one voxel thick gets that voxel's width.
  const Box3 own = volume.bounds();
  bounds_ = cells_over ? *cells_over : own;
  for (int a = 0; a < 3; ++a)
    if (vd[a] == 1 && bounds_.hi[a] - bounds_.lo[a] < 0.5f * sp[a]) {
      bounds_.lo[a] -= 0.5f * sp[a];
      bounds_.hi[a] += 0.5f * sp[a];
    }
  const Vec3 extent = bounds_.extent();
  dims_ = sat_dims(extent, resolution);
  for (int a = 0; a < 3; ++a) cell_[a] = extent[a] / static_cast<float>(dims_[a]);
  const float voxel_in_cells = std::max(sp.x / cell_.x, std::max(sp.y / cell_.y, sp.z / cell_.z));
  reach_ = 1 + static_cast<int>(std::ceil(voxel_in_cells - 1e-4f));

  // Which cell each voxel centre falls in, per axis (monotone, so every cell owns a run of voxels).
  std::array<std::vector<int>, 3> first_voxel;  // first_voxel[a][c] .. first_voxel[a][c + 1]: voxels of cell c
  for (int a = 0; a < 3; ++a) {
    auto& fv = first_voxel[a];
    fv.assign(static_cast<std::size_t>(dims_[a]) + 1, vd[a]);
    const float offset = own.lo[a] - bounds_.lo[a];  // the first voxel's centre from the cells' corner
    for (int i = vd[a] - 1; i >= 0; --i) {
      const float x = vd[a] == 1 ? 0.5f * (bounds_.hi[a] - bounds_.lo[a]) : offset + static_cast<float>(i) * sp[a];
      fv[static_cast<std::size_t>(std::clamp(static_cast<int>(std::floor(x / cell_[a])), 0, dims_[a] - 1))] = i;
    }
    for (int c = dims_[a] - 1; c >= 0; --c)  // a cell without voxels gets the empty run [next, next)
      fv[static_cast<std::size_t>(c)] = std::min(fv[static_cast<std::size_t>(c)], fv[static_cast<std::size_t>(c) + 1]);
  }

  const ExtinctionTable table(tf, compositing, reference_step, std::min(volume.min_value(), finer ? finer->min_value() : volume.min_value()),
                              std::max(volume.max_value(), finer ? finer->max_value() : volume.max_value()));
  const std::size_t cells = cell_count();
  tau_.assign(cells, 0.0f);
  if (with_colour) tau_colour_.assign(cells * 3, 0.0f);
  const int nx = dims_[0], ny = dims_[1];
  if (brick) cell_means_of_brick(volume, table, first_voxel, *brick, with_colour);
  else parallel_for(static_cast<std::size_t>(dims_[2]), [&](std::size_t k0, std::size_t k1) {
    std::vector<double> acc(static_cast<std::size_t>(nx) * ny * 4);
    std::vector<int> count(static_cast<std::size_t>(nx) * ny);
    for (int ck = static_cast<int>(k0); ck < static_cast<int>(k1); ++ck) {
      std::fill(acc.begin(), acc.end(), 0.0);
      std::fill(count.begin(), count.end(), 0);
      for (int k = first_voxel[2][static_cast<std::size_t>(ck)]; k < first_voxel[2][static_cast<std::size_t>(ck) + 1]; ++k)
        for (int cj = 0; cj < ny; ++cj)
          for (int j = first_voxel[1][static_cast<std::size_t>(cj)]; j < first_voxel[1][static_cast<std::size_t>(cj) + 1]; ++j)
            for (int ci = 0; ci < nx; ++ci) {
              const std::size_t c = static_cast<std::size_t>(cj) * nx + ci;
              for (int i = first_voxel[0][static_cast<std::size_t>(ci)]; i < first_voxel[0][static_cast<std::size_t>(ci) + 1]; ++i) {
                const auto e = table.lookup(volume.value(i, j, k));
                for (int q = 0; q < 4; ++q) acc[c * 4 + q] += e[q];
                ++count[c];
              }
            }
      for (int cj = 0; cj < ny; ++cj)
        for (int ci = 0; ci < nx; ++ci) {
          const std::size_t c = static_cast<std::size_t>(cj) * nx + ci;
          std::array<float, 4> mean;
          if (count[c] > 0) {
            for (int q = 0; q < 4; ++q) mean[q] = static_cast<float>(acc[c * 4 + q] / count[c]);
          } else {  // a cell finer than the data: the trilinear sample at its centre
            mean = table.lookup(volume.sample(cell_center(ci, cj, ck)));
          }
          const std::size_t idx = cell_index(ci, cj, ck);
          tau_[idx] = mean[0];
          if (with_colour)
            for (int q = 0; q < 3; ++q) tau_colour_[idx * 3 + q] = mean[q + 1];
        }
    }
  });

  if (finer) refined_cells_ = cell_means_of_finer(*finer, table, with_colour);
  if (clip && !clip->empty()) keep_unclipped(*clip);
  if (spheres) add_spheres(*spheres);

  // Prefix sums along x, then y, then z (each pass parallel over the lines it does not run along).
  auto build_table = [&](const std::vector<float>& source, std::size_t stride, std::vector<double>& sat) {
    const std::size_t sx = static_cast<std::size_t>(nx) + 1, sy = static_cast<std::size_t>(ny) + 1;
    const std::size_t sz = static_cast<std::size_t>(dims_[2]) + 1;
    sat.assign(sx * sy * sz * stride, 0.0);
    parallel_for(static_cast<std::size_t>(dims_[2]), [&](std::size_t k0, std::size_t k1) {
      for (std::size_t k = k0; k < k1; ++k)
        for (int j = 0; j < ny; ++j) {
          double* row = &sat[sat_index(0, j + 1, static_cast<int>(k) + 1) * stride];
          const float* src = &source[cell_index(0, j, static_cast<int>(k)) * stride];
          for (std::size_t q = 0; q < stride; ++q) {
            double run = 0;
            for (int i = 0; i < nx; ++i) {
              run += src[static_cast<std::size_t>(i) * stride + q];
              row[(static_cast<std::size_t>(i) + 1) * stride + q] = run;
            }
          }
        }
    });
    const std::size_t row_len = sx * stride;
    parallel_for(sz, [&](std::size_t k0, std::size_t k1) {
      for (std::size_t k = std::max<std::size_t>(k0, 1); k < k1; ++k)
        for (std::size_t j = 1; j < sy; ++j) {
          double* row = &sat[(k * sy + j) * row_len];
          const double* prev = row - row_len;
          for (std::size_t i = 0; i < row_len; ++i) row[i] += prev[i];
        }
    });
    const std::size_t plane = sy * row_len;
    parallel_for(sy, [&](std::size_t j0, std::size_t j1) {
      for (std::size_t k = 1; k < sz; ++k)
        for (std::size_t j = j0; j < j1; ++j) {
          double* row = &sat[k * plane + j * row_len];
          const double* prev = row - plane;
          for (std::size_t i = 0; i < row_len; ++i) row[i] += prev[i];
        }
    });
  };
  build_table(tau_, 1, sat_);
  if (with_colour) build_table(tau_colour_, 3, sat_colour_);
}

template <class Table>
std::int64_t ExtinctionSat::cell_means_of_finer(const Volume& finer, const Table& table, bool with_colour) {
  // Per axis: the cells [c0, c1) whose extent lies within the box's voxel centres, and the box's voxels
  // of each cell by the constructor's rule (a voxel belongs to the cell its centre falls in).
  const std::array<int, 3> fd = finer.dims();
  const Box3 fb = finer.bounds();
  const Vec3& sp = finer.spacing();
  std::array<int, 3> c0{}, c1{};
  std::array<std::vector<int>, 3> first_voxel;
  for (int a = 0; a < 3; ++a) {
    const double lo = (static_cast<double>(fb.lo[a]) - bounds_.lo[a]) / cell_[a];
    const double hi = (static_cast<double>(fb.hi[a]) - bounds_.lo[a]) / cell_[a];
    constexpr double kSlack = 1e-4;  // of a cell: a box edge on a cell edge covers it despite rounding
    c0[a] = std::max(0, static_cast<int>(std::ceil(lo - kSlack)));
    c1[a] = std::min(dims_[a], static_cast<int>(std::floor(hi + kSlack)));
    if (c1[a] <= c0[a] || fd[a] < 2) return 0;
    auto& fv = first_voxel[a];
    fv.assign(static_cast<std::size_t>(dims_[a]) + 1, fd[a]);
    for (int i = fd[a] - 1; i >= 0; --i) {
      const float x = fb.lo[a] + static_cast<float>(i) * sp[a] - bounds_.lo[a];
      const int c = static_cast<int>(std::floor(x / cell_[a]));
      if (c >= 0 && c < dims_[a]) fv[static_cast<std::size_t>(c)] = i;
    }
    for (int c = dims_[a] - 1; c >= 0; --c)
      fv[static_cast<std::size_t>(c)] = std::min(fv[static_cast<std::size_t>(c)], fv[static_cast<std::size_t>(c) + 1]);
  }
  // Per slab of cells along z, the box's rows in memory order (as the constructor sums the volume's),
  // each voxel added to its cell's sums.
  const int nx = c1[0] - c0[0], ny = c1[1] - c0[1];
  parallel_for(static_cast<std::size_t>(c1[2] - c0[2]), [&](std::size_t k0, std::size_t k1) {
    std::vector<double> acc(static_cast<std::size_t>(nx) * ny * 4);
    for (int ck = c0[2] + static_cast<int>(k0); ck < c0[2] + static_cast<int>(k1); ++ck) {
      std::fill(acc.begin(), acc.end(), 0.0);
      const int z0 = first_voxel[2][static_cast<std::size_t>(ck)], z1 = first_voxel[2][static_cast<std::size_t>(ck) + 1];
      for (int k = z0; k < z1; ++k)
        for (int cj = c0[1]; cj < c1[1]; ++cj)
          for (int j = first_voxel[1][static_cast<std::size_t>(cj)]; j < first_voxel[1][static_cast<std::size_t>(cj) + 1]; ++j)
            for (int ci = c0[0]; ci < c1[0]; ++ci) {
              double* a = &acc[(static_cast<std::size_t>(cj - c0[1]) * nx + static_cast<std::size_t>(ci - c0[0])) * 4];
              for (int i = first_voxel[0][static_cast<std::size_t>(ci)]; i < first_voxel[0][static_cast<std::size_t>(ci) + 1]; ++i) {
                const auto e = table.lookup(finer.value(i, j, k));
                for (int q = 0; q < 4; ++q) a[q] += e[q];
              }
            }
      for (int cj = c0[1]; cj < c1[1]; ++cj)
        for (int ci = c0[0]; ci < c1[0]; ++ci) {
          const double* a = &acc[(static_cast<std::size_t>(cj - c0[1]) * nx + static_cast<std::size_t>(ci - c0[0])) * 4];
          const double n = static_cast<double>(first_voxel[0][static_cast<std::size_t>(ci) + 1] - first_voxel[0][static_cast<std::size_t>(ci)]) *
                           (first_voxel[1][static_cast<std::size_t>(cj) + 1] - first_voxel[1][static_cast<std::size_t>(cj)]) * (z1 - z0);
          std::array<double, 4> mean{};
          if (n == 0) {  // a cell finer than the box's voxels: the box's trilinear sample at its centre
            const auto e = table.lookup(finer.sample(cell_center(ci, cj, ck)));
            for (int q = 0; q < 4; ++q) mean[q] = e[q];
          } else {
            for (int q = 0; q < 4; ++q) mean[q] = a[q] / n;
          }
          const std::size_t idx = cell_index(ci, cj, ck);
          tau_[idx] = static_cast<float>(mean[0]);
          if (with_colour)
            for (int q = 0; q < 3; ++q) tau_colour_[idx * 3 + static_cast<std::size_t>(q)] = static_cast<float>(mean[q + 1]);
        }
    }
  });
  return static_cast<std::int64_t>(c1[0] - c0[0]) * (c1[1] - c0[1]) * (c1[2] - c0[2]);
}

template <class Table>
void ExtinctionSat::cell_means_of_brick(const Volume& volume, const Table& table, const std::array<std::vector<int>, 3>& first_voxel,
                                        const ShadowBrick& brick, bool with_colour) {
  // per cell: Σ τ, Σ τ·c and the voxel count of this brick's voxels; a cell without voxels gets the
  // sample at its centre from the brick that owns the centre
  const int nx = dims_[0], ny = dims_[1];
  const std::size_t cells = cell_count();
  std::vector<double> sums(cells * 5, 0.0);
  const int first_slice = volume.window_first(), slices = volume.dims()[2];
  const float z0 = bounds_.lo.z, dz = volume.spacing().z;
  parallel_for(static_cast<std::size_t>(dims_[2]), [&](std::size_t k0, std::size_t k1) {
    for (int ck = static_cast<int>(k0); ck < static_cast<int>(k1); ++ck) {
      const int kz0 = first_voxel[2][static_cast<std::size_t>(ck)], kz1 = first_voxel[2][static_cast<std::size_t>(ck) + 1];
      for (int k = std::max(kz0, first_slice); k < std::min(kz1, first_slice + slices); ++k) {
        if (!brick.slab.owns({0, 0, z0 + static_cast<float>(k) * dz})) continue;  // another brick's voxel
        for (int cj = 0; cj < ny; ++cj)
          for (int j = first_voxel[1][static_cast<std::size_t>(cj)]; j < first_voxel[1][static_cast<std::size_t>(cj) + 1]; ++j)
            for (int ci = 0; ci < nx; ++ci) {
              double* s = &sums[cell_index(ci, cj, ck) * 5];
              for (int i = first_voxel[0][static_cast<std::size_t>(ci)]; i < first_voxel[0][static_cast<std::size_t>(ci) + 1]; ++i) {
                const auto e = table.lookup(volume.value(i, j, k - first_slice));
                for (int q = 0; q < 4; ++q) s[q] += e[q];
                s[4] += 1;
              }
            }
      }
      for (int cj = 0; cj < ny; ++cj)
        for (int ci = 0; ci < nx; ++ci) {
          const bool voxelless = kz0 == kz1 || first_voxel[1][static_cast<std::size_t>(cj)] == first_voxel[1][static_cast<std::size_t>(cj) + 1] ||
                                 first_voxel[0][static_cast<std::size_t>(ci)] == first_voxel[0][static_cast<std::size_t>(ci) + 1];
          const Vec3 centre = cell_center(ci, cj, ck);
          if (!voxelless || !brick.slab.owns(centre)) continue;
          const auto e = table.lookup(volume.sample(centre));
          for (int q = 0; q < 4; ++q) sums[cell_index(ci, cj, ck) * 5 + static_cast<std::size_t>(q)] = e[q];
        }
    }
  });
  brick.reduction->sum(sums);
  for (std::size_t c = 0; c < cells; ++c) {
    const double* s = &sums[c * 5];
    const double n = s[4] > 0 ? s[4] : 1.0;  // a voxel-less cell holds its centre's sample
    tau_[c] = static_cast<float>(s[0] / n);
    if (with_colour)
      for (int q = 0; q < 3; ++q) tau_colour_[c * 3 + static_cast<std::size_t>(q)] = static_cast<float>(s[q + 1] / n);
  }
}

void ExtinctionSat::keep_unclipped(const ClipPlanes& clip) {
  // each cell keeps the fraction of its 4³ sub-cell centres that the planes keep
  constexpr int kSub = 4;
  parallel_for(static_cast<std::size_t>(dims_[2]), [&](std::size_t k0, std::size_t k1) {
    for (int k = static_cast<int>(k0); k < static_cast<int>(k1); ++k)
      for (int j = 0; j < dims_[1]; ++j)
        for (int i = 0; i < dims_[0]; ++i) {
          int kept = 0;
          for (int q = 0; q < kSub * kSub * kSub; ++q) {
            const Vec3 f{(static_cast<float>(q % kSub) + 0.5f) / kSub, (static_cast<float>((q / kSub) % kSub) + 0.5f) / kSub,
                         (static_cast<float>(q / (kSub * kSub)) + 0.5f) / kSub};
            const Vec3 p = bounds_.lo + Vec3{(static_cast<float>(i) + f.x) * cell_.x, (static_cast<float>(j) + f.y) * cell_.y,
                                             (static_cast<float>(k) + f.z) * cell_.z};
            kept += clip.removes(p) ? 0 : 1;
          }
          if (kept == kSub * kSub * kSub) continue;
          const float fraction = static_cast<float>(kept) / (kSub * kSub * kSub);
          const std::size_t idx = cell_index(i, j, k);
          tau_[idx] *= fraction;
          if (!tau_colour_.empty())
            for (int c = 0; c < 3; ++c) tau_colour_[idx * 3 + static_cast<std::size_t>(c)] *= fraction;
        }
  });
}

void ExtinctionSat::add_spheres(const ParticleSet& spheres) {
  // in file order, one sphere after another: the same sums for any thread count
  const float cell = (cell_.x + cell_.y + cell_.z) / 3.0f;
  for (std::size_t n = 0; n < spheres.size(); ++n) {
    const Sphere& s = spheres.spheres[n];
    const SphereClip clip = spheres.clip_of(n);  // a cut sphere fills the cells whose centres it keeps
    if (!(s.radius > 0) || clip == kSphereRemoved) continue;
    const float tau = static_cast<float>(kOpaqueDepth) / (2.0f * s.radius);
    const Vec3 lo = to_cell(s.center - Vec3{s.radius, s.radius, s.radius});
    const Vec3 hi = to_cell(s.center + Vec3{s.radius, s.radius, s.radius});
    const int i0 = std::max(0, floor_int(lo.x) - 1), i1 = std::min(dims_[0] - 1, floor_int(hi.x) + 1);
    const int j0 = std::max(0, floor_int(lo.y) - 1), j1 = std::min(dims_[1] - 1, floor_int(hi.y) + 1);
    const int k0 = std::max(0, floor_int(lo.z) - 1), k1 = std::min(dims_[2] - 1, floor_int(hi.z) + 1);
    for (int k = k0; k <= k1; ++k)
      for (int j = j0; j <= j1; ++j)
        for (int i = i0; i <= i1; ++i) {
          const float inside = clamp(0.5f + (s.radius - length(cell_center(i, j, k) - s.center)) / cell, 0, 1);
          if (clip != kSphereWhole && spheres.clip_planes.removes(cell_center(i, j, k))) continue;
          if (inside > 0) tau_[cell_index(i, j, k)] += inside * tau;
        }
  }
}

Rgb ExtinctionSat::tau_colour(int i, int j, int k) const {
  if (!has_colour()) throw Error("extinction SAT built without colour");
  const std::size_t idx = cell_index(i, j, k) * 3;
  return {tau_colour_[idx], tau_colour_[idx + 1], tau_colour_[idx + 2]};
}

std::array<double, 3> ExtinctionSat::sum_colour(const CellBox& box) const {
  if (!has_colour()) throw Error("extinction SAT built without colour");
  std::array<int, 3> lo, hi;
  if (!clip(box, lo, hi)) return {0, 0, 0};
  return {corners(sat_colour_.data(), 3, 0, lo, hi), corners(sat_colour_.data(), 3, 1, lo, hi),
          corners(sat_colour_.data(), 3, 2, lo, hi)};
}

}  // namespace penumbra
