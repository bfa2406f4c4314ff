// Values kept at the cell centres of an extinction SAT's grid and fetched trilinearly at world points:
// the storage of paper 001's light cache (Algorithm 1), which the ray caster reads with one fetch per
// sample. Points beyond the outermost centres take the border values.
//
// Only the cells near extinction (ExtinctionSat::near_extinction) are filled; the others hold NaN, so a
// fetch that touches one comes back NaN and try_fetch() tells the caller to evaluate the point directly.
#pragma once

#include <cmath>
#include <limits>
#include <vector>

#include "penumbra/accel/extinction_sat.h"
#include "penumbra/core/color.h"
#include "penumbra/core/parallel.h"

namespace penumbra {

template <class T>
class CellField {
public:
  CellField() = default;
  explicit CellField(const ExtinctionSat& sat, T fill = T{})
      : dims_(sat.dims()),
        bounds_(sat.bounds()),
        origin_(sat.bounds().lo),
        inv_cell_{1.0f / sat.cell_size().x, 1.0f / sat.cell_size().y, 1.0f / sat.cell_size().z},
        values_(sat.cell_count(), fill) {}

  T& operator[](std::size_t index) { return values_[index]; }
  const T& operator[](std::size_t index) const { return values_[index]; }
  std::size_t size() const { return values_.size(); }
  std::size_t memory_bytes() const { return values_.size() * sizeof(T); }

  // Fills the cells near extinction with value(i, j, k), in parallel over rows; the others are not cached.
  template <class Value>
  void fill_near_extinction(const ExtinctionSat& sat, Value&& value) {
    parallel_for(static_cast<std::size_t>(dims_[2]) * dims_[1], [&](std::size_t r0, std::size_t r1) {
      for (std::size_t r = r0; r < r1; ++r) {
        const int j = static_cast<int>(r % dims_[1]), k = static_cast<int>(r / dims_[1]);
        for (int i = 0; i < dims_[0]; ++i)
          values_[sat.cell_index(i, j, k)] = sat.near_extinction(i, j, k) ? value(i, j, k) : T(kNotCached);
      }
    });
  }

  // The cached value at p; false when p lies outside the grid's box or next to a cell left unfilled.
  bool try_fetch(const Vec3& p, T& out) const {
    if (!bounds_.contains(p)) return false;
    out = fetch(p);
    return !is_nan(out);
  }

  T fetch(const Vec3& p) const {
    int i0[3], i1[3];
    float t[3];
    for (int a = 0; a < 3; ++a) {
      // centre of cell i sits at continuous coordinate i + 0.5
      const float c = clamp((p[a] - origin_[a]) * inv_cell_[a] - 0.5f, 0.0f, static_cast<float>(dims_[a] - 1));
      i0[a] = static_cast<int>(c);
      i1[a] = std::min(i0[a] + 1, dims_[a] - 1);
      t[a] = c - static_cast<float>(i0[a]);
    }
    auto at = [&](int i, int j, int k) {
      return values_[(static_cast<std::size_t>(k) * dims_[1] + j) * dims_[0] + i];
    };
    const T x00 = at(i0[0], i0[1], i0[2]) * (1 - t[0]) + at(i1[0], i0[1], i0[2]) * t[0];
    const T x10 = at(i0[0], i1[1], i0[2]) * (1 - t[0]) + at(i1[0], i1[1], i0[2]) * t[0];
    const T x01 = at(i0[0], i0[1], i1[2]) * (1 - t[0]) + at(i1[0], i0[1], i1[2]) * t[0];
    const T x11 = at(i0[0], i1[1], i1[2]) * (1 - t[0]) + at(i1[0], i1[1], i1[2]) * t[0];
    const T y0 = x00 * (1 - t[1]) + x10 * t[1];
    const T y1 = x01 * (1 - t[1]) + x11 * t[1];
    return y0 * (1 - t[2]) + y1 * t[2];
  }

private:
  static constexpr float kNotCached = std::numeric_limits<float>::quiet_NaN();
  static bool is_nan(float v) { return std::isnan(v); }
  static bool is_nan(const Rgb& v) { return std::isnan(v.r); }

  std::array<int, 3> dims_{0, 0, 0};
  Box3 bounds_;
  Vec3 origin_, inv_cell_{1, 1, 1};
  std::vector<T> values_;
};

}  // namespace penumbra
