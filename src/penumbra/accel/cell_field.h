// Values kept at the cell centres of an extinction SAT's grid and fetched trilinearly at world points:
// the storage of paper 001's light cache (Algorithm 1), which the ray caster reads with one fetch per
// sample. Points beyond the outermost centres take the border values.
//
// Only the cells near extinction (ExtinctionSat::near_extinction) are filled; the others hold NaN, so a
// fetch that touches one comes back NaN and try_fetch() tells the caller to evaluate the point directly.
#pragma once

#include <array>
#include <cmath>
#include <limits>
#include <vector>

#include "penumbra/accel/extinction_sat.h"
#include "penumbra/core/color.h"
#include "penumbra/core/parallel.h"

namespace penumbra {

// The eight cell centres around a point and its fractions between them, per axis.
struct CellCorners {
  int i0[3], i1[3];
  float t[3];
  std::size_t index(int dims0, int dims1, bool x, bool y, bool z) const {
    return (static_cast<std::size_t>(z ? i1[2] : i0[2]) * dims1 + (y ? i1[1] : i0[1])) * dims0 + (x ? i1[0] : i0[0]);
  }
};

// A SAT's cell lattice as seen by a cache: its box and where a point falls between the cell centres.
struct CellLattice {
  std::array<int, 3> dims{0, 0, 0};
  Box3 bounds;
  Vec3 origin, inv_cell{1, 1, 1};

  CellLattice() = default;
  explicit CellLattice(const ExtinctionSat& sat)
      : dims(sat.dims()),
        bounds(sat.bounds()),
        origin(sat.bounds().lo),
        inv_cell{1.0f / sat.cell_size().x, 1.0f / sat.cell_size().y, 1.0f / sat.cell_size().z} {}

  std::size_t cell_count() const { return static_cast<std::size_t>(dims[0]) * dims[1] * dims[2]; }
  bool same_cells(const CellLattice& o) const {
    return dims == o.dims && bounds.lo == o.bounds.lo && bounds.hi == o.bounds.hi;
  }

  CellCorners corners(const Vec3& p) const {
    CellCorners c;
    for (int a = 0; a < 3; ++a) {
      // centre of cell i sits at continuous coordinate i + 0.5
      const float x = clamp((p[a] - origin[a]) * inv_cell[a] - 0.5f, 0.0f, static_cast<float>(dims[a] - 1));
      c.i0[a] = static_cast<int>(x);
      c.i1[a] = std::min(c.i0[a] + 1, dims[a] - 1);
      c.t[a] = x - static_cast<float>(c.i0[a]);
    }
    return c;
  }

  // Trilinear interpolation of at(cell index) between the corners (x first, then y, then z).
  template <class T, class At>
  T interpolate(const CellCorners& c, At&& at) const {
    auto v = [&](bool x, bool y, bool z) { return at(c.index(dims[0], dims[1], x, y, z)); };
    const float* t = c.t;
    const T x00 = v(0, 0, 0) * (1 - t[0]) + v(1, 0, 0) * t[0];
    const T x10 = v(0, 1, 0) * (1 - t[0]) + v(1, 1, 0) * t[0];
    const T x01 = v(0, 0, 1) * (1 - t[0]) + v(1, 0, 1) * t[0];
    const T x11 = v(0, 1, 1) * (1 - t[0]) + v(1, 1, 1) * t[0];
    const T y0 = x00 * (1 - t[1]) + x10 * t[1];
    const T y1 = x01 * (1 - t[1]) + x11 * t[1];
    return y0 * (1 - t[2]) + y1 * t[2];
  }
};

inline constexpr float kNotCached = std::numeric_limits<float>::quiet_NaN();

template <class T>
class CellField {
public:
  CellField() = default;
  explicit CellField(const ExtinctionSat& sat, T fill = T{}) : lattice_(sat), values_(sat.cell_count(), fill) {}

  T& operator[](std::size_t index) { return values_[index]; }
  const T& operator[](std::size_t index) const { return values_[index]; }
  std::size_t size() const { return values_.size(); }
  std::size_t memory_bytes() const { return values_.size() * sizeof(T); }
  const CellLattice& lattice() const { return lattice_; }

  // Fills the cells near extinction with value(i, j, k), in parallel over rows; the others are not cached.
  template <class Value>
  void fill_near_extinction(const ExtinctionSat& sat, Value&& value) {
    const auto& dims = lattice_.dims;
    parallel_for(static_cast<std::size_t>(dims[2]) * dims[1], [&](std::size_t r0, std::size_t r1) {
      for (std::size_t r = r0; r < r1; ++r) {
        const int j = static_cast<int>(r % dims[1]), k = static_cast<int>(r / dims[1]);
        for (int i = 0; i < dims[0]; ++i)
          values_[sat.cell_index(i, j, k)] = sat.near_extinction(i, j, k) ? value(i, j, k) : T(kNotCached);
      }
    });
  }

  // The cached value at p; false when p lies outside the grid's box or next to a cell left unfilled.
  bool try_fetch(const Vec3& p, T& out) const {
    if (!lattice_.bounds.contains(p)) return false;
    out = fetch(p);
    return !is_nan(out);
  }

  T fetch(const Vec3& p) const {
    return lattice_.interpolate<T>(lattice_.corners(p), [&](std::size_t i) { return values_[i]; });
  }

private:
  static bool is_nan(float v) { return std::isnan(v); }
  static bool is_nan(const Rgb& v) { return std::isnan(v.r); }

  CellLattice lattice_;
  std::vector<T> values_;
};

}  // namespace penumbra
