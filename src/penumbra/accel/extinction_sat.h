// The extinction volume of paper 001 (Schlegel, Makhinya & Pajarola, §3.1) and its 3D summed area table.
//
// The volume's box is cut into cells at a resolution chosen independently of the data (`resolution`
// cells along the longest side, proportionally many along the others, so cells stay near-cubic). Each
// cell holds the mean extinction τ (per world unit) of the data voxels whose centres fall inside it
// (classified first, then averaged; a cell finer than the data takes the trilinear sample at its
// centre), and, for colour bleeding, the mean of τ·c with c the transfer function's colour.
//
// The SAT S(i, j, k) = Σ τ over the cells (a, b, c) with a < i, b < j, c < k, stored with its zero
// border, answers the τ-sum of any cell box with at most eight lookups (sum()).
//
// Accumulation type: double. A 256³ table sums up to 1.7·10⁷ cells; in float32 (24-bit mantissa) the
// prefix sums carry an absolute error of about 2⁻²⁴ of the whole-volume sum, which for a small box deep
// in the table is larger than the box's own sum (tests/test_extinction.cpp measures it). double's
// 53 bits leave the box sums exact to ~10⁻⁹ relative of the total. Integer fixed point with wrap-around
// arithmetic would be exact too, but needs a quantisation of τ that thin media (τ ~ 10⁻³) do not survive.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "penumbra/core/color.h"
#include "penumbra/core/math.h"
#include "penumbra/data/particles.h"
#include "penumbra/data/transfer_function.h"
#include "penumbra/data/volume.h"
#include "penumbra/accel/brick_reduction.h"

namespace penumbra {

constexpr int kMinSatResolution = 4;
constexpr int kMaxSatResolution = 512;

// A half-open box of cells [lo, hi) per axis.
struct CellBox {
  std::array<int, 3> lo{0, 0, 0};
  std::array<int, 3> hi{0, 0, 0};
  std::int64_t count() const {
    std::int64_t n = 1;
    for (int a = 0; a < 3; ++a) n *= std::max(0, hi[a] - lo[a]);
    return n;
  }
};

class ExtinctionSat {
public:
  // `reference_step`: the world length the transfer function's opacities refer to (one voxel).
  // `with_colour`: also build the table of τ·c (colour bleeding), in the same pass.
  // `spheres` (optional): opaque spheres that enter the table too, each cell by the fraction of it a
  // sphere fills (a ramp one cell wide across the surface) times τ_s = kOpaqueDepth / (2r), so that a
  // ray through a sphere's diameter loses all but 10⁻⁴ of its light (spheres outside the volume's box
  // are not in the table).
  // `brick` (a distributed frame, accel/brick_reduction.h): `volume` may be a window of the whole grid;
  // this brick sums the voxels whose centres its slab owns (and samples the voxel-less cells whose
  // centres it owns), and the bricks' sums are added up before the means are taken, so that every
  // brick holds the whole volume's table (the same up to the order of the double sums).
  // `clip` (optional): the clip planes that cut the volume; each cell keeps the fraction of it they keep.
  // `finer` (optional, not with `brick`): a box of a finer level of the same volume (a refined view's,
  // render/view_refinement.h). The cells stay `volume`'s; each cell that lies wholly inside the box's
  // voxel centres takes the mean of the box's voxels whose centres fall in it, as a table built from
  // that level in memory would hold there; the others keep `volume`'s means. The extinction is
  // tabulated over both value ranges.
  // `cells_over` (optional, not with `brick`): the box the cells divide, when it is not the volume's own —
  // a pyramid's finest level's voxel centres, which a coarser level's lie inside, so that every level
  // (and a finer box) shares the cells a table of the finest level has.
  ExtinctionSat(const Volume& volume, const TransferFunction& tf, Compositing compositing, float reference_step,
                int resolution, bool with_colour, const ParticleSet* spheres = nullptr, const ShadowBrick* brick = nullptr,
                const ClipPlanes* clip = nullptr, const Volume* finer = nullptr, const Box3* cells_over = nullptr);

  const std::array<int, 3>& dims() const { return dims_; }
  const Box3& bounds() const { return bounds_; }
  const Vec3& cell_size() const { return cell_; }
  float cell_volume() const { return cell_.x * cell_.y * cell_.z; }
  bool has_colour() const { return !sat_colour_.empty(); }
  // How many cells took their means from a finer box (the constructor's `finer`); 0 without one.
  std::int64_t refined_cells() const { return refined_cells_; }

  // Continuous cell coordinates of a world point: cell i spans [i, i + 1).
  Vec3 to_cell(const Vec3& p) const {
    return {(p.x - bounds_.lo.x) / cell_.x, (p.y - bounds_.lo.y) / cell_.y, (p.z - bounds_.lo.z) / cell_.z};
  }
  Vec3 cell_center(int i, int j, int k) const {
    return {bounds_.lo.x + (static_cast<float>(i) + 0.5f) * cell_.x, bounds_.lo.y + (static_cast<float>(j) + 0.5f) * cell_.y,
            bounds_.lo.z + (static_cast<float>(k) + 0.5f) * cell_.z};
  }
  std::size_t cell_index(int i, int j, int k) const {
    return (static_cast<std::size_t>(k) * dims_[1] + j) * dims_[0] + i;
  }
  std::size_t cell_count() const { return static_cast<std::size_t>(dims_[0]) * dims_[1] * dims_[2]; }

  // Mean extinction of one cell (per world unit) and its colour-weighted mean τ·c.
  float tau(int i, int j, int k) const { return tau_[cell_index(i, j, k)]; }
  Rgb tau_colour(int i, int j, int k) const;  // requires has_colour()

  // Σ τ over the cells of `box` clipped to the grid (cells outside count as τ = 0): eight lookups.
  double sum(const CellBox& box) const {
    std::array<int, 3> lo, hi;
    if (!clip(box, lo, hi)) return 0.0;
    return corners(sat_.data(), 1, 0, lo, hi);
  }
  // The same for τ·c, per channel (requires has_colour()).
  std::array<double, 3> sum_colour(const CellBox& box) const;

  // Whether any cell within `reach()` cells of (i, j, k) has τ > 0. The light cache is filled only there:
  // elsewhere no ray-caster sample can weigh it (a visible sample lies within one voxel of a voxel with
  // τ > 0, and its trilinear fetch reads the centres of the neighbouring cells).
  bool near_extinction(int i, int j, int k) const {
    return sum(CellBox{{i - reach_, j - reach_, k - reach_}, {i + reach_ + 1, j + reach_ + 1, k + reach_ + 1}}) > 0;
  }
  int reach() const { return reach_; }

  std::size_t memory_bytes() const {
    return sat_.size() * sizeof(double) + sat_colour_.size() * sizeof(double) + tau_.size() * sizeof(float) +
           tau_colour_.size() * sizeof(float);
  }

private:
  void add_spheres(const ParticleSet& spheres);
  void keep_unclipped(const ClipPlanes& clip);
  // The cells' means from every brick's sums (see the constructor).
  // The means of `finer`'s voxels in the cells wholly inside its box (see the constructor); the cells refined.
  template <class Table>
  std::int64_t cell_means_of_finer(const Volume& finer, const Table& table, bool with_colour);
  template <class Table>
  void cell_means_of_brick(const Volume& volume, const Table& table, const std::array<std::vector<int>, 3>& first_voxel,
                           const ShadowBrick& brick, bool with_colour);
  bool clip(const CellBox& box, std::array<int, 3>& lo, std::array<int, 3>& hi) const {
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::clamp(box.lo[a], 0, dims_[a]);
      hi[a] = std::clamp(box.hi[a], 0, dims_[a]);
      if (hi[a] <= lo[a]) return false;
    }
    return true;
  }
  std::size_t sat_index(int i, int j, int k) const {
    return (static_cast<std::size_t>(k) * (dims_[1] + 1) + j) * (dims_[0] + 1) + i;
  }
  // Inclusion–exclusion over the box's eight corners in a table of `stride` values per entry.
  double corners(const double* table, std::size_t stride, std::size_t channel, const std::array<int, 3>& lo,
                 const std::array<int, 3>& hi) const {
    auto at = [&](int i, int j, int k) { return table[sat_index(i, j, k) * stride + channel]; };
    return at(hi[0], hi[1], hi[2]) - at(lo[0], hi[1], hi[2]) - at(hi[0], lo[1], hi[2]) - at(hi[0], hi[1], lo[2]) +
           at(lo[0], lo[1], hi[2]) + at(lo[0], hi[1], lo[2]) + at(hi[0], lo[1], lo[2]) - at(lo[0], lo[1], lo[2]);
  }

  std::array<int, 3> dims_{0, 0, 0};
  Box3 bounds_;
  Vec3 cell_{1, 1, 1};
  int reach_ = 2;
  std::int64_t refined_cells_ = 0;
  std::vector<float> tau_;          // per cell
  std::vector<float> tau_colour_;   // per cell, 3 channels
  std::vector<double> sat_;         // (dims + 1)³
  std::vector<double> sat_colour_;  // (dims + 1)³ x 3
};

// Cell counts of a SAT of `resolution` cells along the longest side of a box of extent `extent`.
std::array<int, 3> sat_dims(const Vec3& extent, int resolution);

}  // namespace penumbra
