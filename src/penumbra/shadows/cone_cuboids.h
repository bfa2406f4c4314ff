// The shadow cone of paper 001 (§3.3, Fig. 7) as a series of axis-aligned cuboids of SAT cells.
//
// From an apex p towards a light in direction ℓ, the main axis m is the coordinate axis closest to ℓ.
// Along it, slab boundaries are cell planes: the first slab runs from p to the next plane, then each
// slab is `base · (1 + growth)^k` cells thick (base = cells along the longest side / samples per unit,
// rounded to whole planes, at least one cell), up to the light or the grid's far side. For a secondary
// axis a, the cone (half-angle θ) projects onto the (m, a) plane as a wedge whose edges have slopes
// tan(φ₀ ± δ), φ₀ = atan(ℓ_a / |ℓ_m|) and sin δ = sin θ / √(ℓ_m² + ℓ_a²) (the longitude half-width of a
// spherical cap); the slab's cuboid takes the wedge's interval through the slab's mid-plane on both
// secondary axes, widened outwards to whole cells.
//
// Each cuboid contributes its mean extinction (SAT sum / cell count: the paper's weight h = 1 / V_q)
// times the length of the cone's axis inside the slab, so that for θ → 0 the sum tends to the optical
// depth along the shadow ray through the cell grid.
#pragma once

#include <cmath>
#include <vector>

#include "penumbra/accel/extinction_sat.h"
#include "penumbra/core/cutoffs.h"

namespace penumbra {

struct ConeSampling {
  float half_angle = 0;        // radians, in [0, π/2)
  float samples_per_unit = 50; // slabs per longest side of the grid before growth
  float growth = 0;            // relative growth of the slab thickness from one slab to the next
};

struct ConeCuboid {
  CellBox box;           // not clipped to the grid
  float path_length;     // world length of the cone's axis inside the slab
};

// Visits the cuboids from the apex outwards; visit(const ConeCuboid&) returns false to stop.
// `to_light`: unit direction; `distance`: to the light (infinity for directional lights).
// The cone's main axis m, the direction along it, and the wedge slopes on the two secondary axes (in
// cells across per cell along m).
struct ConeAxes {
  int m = 0, sign = 1;
  int sec[2] = {1, 2};
  float slope_lo[2] = {0, 0}, slope_hi[2] = {0, 0};
  float lm = 1;  // |ℓ_m|
};

// False when the direction has no component along any axis (not a direction).
inline bool cone_axes(const ExtinctionSat& sat, const Vec3& to_light, float half_angle, ConeAxes& ax) {
  ax.m = 0;
  for (int a = 1; a < 3; ++a)
    if (std::abs(to_light[a]) > std::abs(to_light[ax.m])) ax.m = a;
  ax.lm = std::abs(to_light[ax.m]);
  if (!(ax.lm > 0)) return false;
  ax.sign = to_light[ax.m] > 0 ? 1 : -1;
  const Vec3 cell = sat.cell_size();
  const float sin_theta = std::sin(half_angle);
  constexpr float kMaxSlope = 57.0f;  // tan 89°: a wedge reaching 90° is clamped there
  for (int q = 0, a = 0; a < 3; ++a) {
    if (a == ax.m) continue;
    ax.sec[q] = a;
    const float t0 = to_light[a] / ax.lm;  // tan φ₀
    const float ca2 = ax.lm * ax.lm + to_light[a] * to_light[a];
    float lo = -kMaxSlope, hi = kMaxSlope;
    if (sin_theta * sin_theta < ca2) {
      const float td = sin_theta / std::sqrt(ca2 - sin_theta * sin_theta);  // tan δ
      const float den_hi = 1 - t0 * td, den_lo = 1 + t0 * td;
      hi = den_hi > 1.0f / kMaxSlope ? std::min((t0 + td) / den_hi, kMaxSlope) : kMaxSlope;
      lo = den_lo > 1.0f / kMaxSlope ? std::max((t0 - td) / den_lo, -kMaxSlope) : -kMaxSlope;
    }
    ax.slope_lo[q] = lo * cell[ax.m] / cell[a];
    ax.slope_hi[q] = hi * cell[ax.m] / cell[a];
    ++q;
  }
  return true;
}

// The cuboid of the slab [u0, u1] (cells from the apex c, continuous cell coordinates, along m).
inline CellBox slab_box(const ConeAxes& ax, const Vec3& c, float u0, float u1) {
  CellBox box;
  const int m = ax.m;
  const float m_lo = ax.sign > 0 ? c[m] + u0 : c[m] - u1, m_hi = ax.sign > 0 ? c[m] + u1 : c[m] - u0;
  box.lo[m] = floor_int(m_lo + 1e-4f);
  box.hi[m] = std::max(box.lo[m] + 1, ceil_int(m_hi - 1e-4f));
  const float um = 0.5f * (u0 + u1);  // the slab's mid-plane
  for (int k = 0; k < 2; ++k) {
    const int a = ax.sec[k];
    box.lo[a] = floor_int(c[a] + um * ax.slope_lo[k]);
    box.hi[a] = floor_int(c[a] + um * ax.slope_hi[k]) + 1;
  }
  return box;
}

// Cells along m from the apex (continuous cell coordinate c_m) to the grid's far side.
inline float cells_to_far_side(const ConeAxes& ax, const ExtinctionSat& sat, float c_m) {
  return ax.sign > 0 ? static_cast<float>(sat.dims()[static_cast<std::size_t>(ax.m)]) - c_m : c_m;
}

// Visits the cuboids from the apex outwards; visit(const ConeCuboid&, float u0, float u1) returns false
// to stop (u0, u1: the slab, cells from the apex along the main axis).
// `to_light`: unit direction; `distance`: to the light (infinity for directional lights).
template <class Visit>
void for_each_cone_slab(const ExtinctionSat& sat, const Vec3& apex, const Vec3& to_light, float distance,
                        const ConeSampling& s, Visit&& visit) {
  ConeAxes ax;
  if (!cone_axes(sat, to_light, s.half_angle, ax)) return;
  const int m = ax.m;
  const Vec3 c = sat.to_cell(apex);  // continuous cell coordinates
  const auto& dims = sat.dims();
  const float cell_m = sat.cell_size()[m];
  // Main-axis extent: from the apex to the light or the grid's far side.
  const float u_light = distance < kInfinity ? distance * ax.lm / cell_m : kInfinity;
  const float u_end = std::min(u_light, cells_to_far_side(ax, sat, c[m]));
  if (!(u_end > 0)) return;
  const float base = std::max(1.0f, static_cast<float>(std::max(dims[0], std::max(dims[1], dims[2]))) / s.samples_per_unit);

  // Distance (cells along m) from the apex to the first cell plane past it, in (0, 1].
  const float first = ax.sign > 0 ? std::floor(c[m]) + 1 - c[m] : c[m] - (std::ceil(c[m]) - 1);
  float u0 = 0, u1 = std::min(first, u_end);  // the slab [u0, u1]
  double target = 0;                          // unrounded planes past `first` so far
  int planes = 0;
  float thickness = base;
  while (true) {
    const ConeCuboid q{slab_box(ax, c, u0, u1), (u1 - u0) * cell_m / ax.lm};
    if (!visit(q, u0, u1) || u1 >= u_end) return;
    target += thickness;
    thickness *= 1 + s.growth;
    planes = std::max(planes + 1, static_cast<int>(target + 0.5));  // target > 0: rounds to nearest
    u0 = u1;
    u1 = std::min(first + static_cast<float>(planes), u_end);
  }
}

// The same, for visitors that do not need the slab's extent.
template <class Visit>
void for_each_cone_cuboid(const ExtinctionSat& sat, const Vec3& apex, const Vec3& to_light, float distance,
                          const ConeSampling& s, Visit&& visit) {
  for_each_cone_slab(sat, apex, to_light, distance, s, [&](const ConeCuboid& q, float, float) { return visit(q); });
}

// Optical depth of the cone: Σ over cuboids of (SAT sum / cell count) · path length.
inline double cone_optical_depth(const ExtinctionSat& sat, const Vec3& apex, const Vec3& to_light, float distance,
                                 const ConeSampling& s) {
  double depth = 0;
  for_each_cone_cuboid(sat, apex, to_light, distance, s, [&](const ConeCuboid& q) {
    depth += sat.sum(q.box) / static_cast<double>(q.box.count()) * q.path_length;
    return depth < kOpaqueDepth;
  });
  return depth;
}


// For a directional light every cell centre sees the same cone shifted by whole cells, so the cuboids
// can be laid out once, relative to the apex cell, and reused for every cell of the light cache: the
// same sums as cone_optical_depth() at cell centres without redoing the geometry per cell. The one
// slab that reaches past the grid's far side is cut there and rebuilt for the cell, as the direct
// evaluation does.
class ConeStencil {
public:
  ConeStencil(const ExtinctionSat& sat, const Vec3& to_light, const ConeSampling& s) {
    if (!cone_axes(sat, to_light, s.half_angle, axes_)) return;
    cell_m_ = sat.cell_size()[axes_.m];
    // apex in the first cell along the main axis, so the stencil spans the whole grid
    std::array<int, 3> apex{0, 0, 0};
    apex[static_cast<std::size_t>(axes_.m)] = axes_.sign > 0 ? 0 : sat.dims()[static_cast<std::size_t>(axes_.m)] - 1;
    for_each_cone_slab(sat, sat.cell_center(apex[0], apex[1], apex[2]), to_light, kInfinity, s,
                       [&](const ConeCuboid& q, float u0, float u1) {
                         Entry e;
                         for (int a = 0; a < 3; ++a) {
                           e.box.lo[a] = q.box.lo[a] - apex[a];
                           e.box.hi[a] = q.box.hi[a] - apex[a];
                         }
                         e.weight = q.path_length / static_cast<double>(q.box.count());
                         e.u0 = u0;
                         e.u1 = u1;
                         entries_.push_back(e);
                         return true;
                       });
  }

  // Optical depth of the cone from the centre of cell (i, j, k).
  double optical_depth(const ExtinctionSat& sat, int i, int j, int k) const {
    const int c[3] = {i, j, k};
    const Vec3 centre{static_cast<float>(i) + 0.5f, static_cast<float>(j) + 0.5f, static_cast<float>(k) + 0.5f};
    const float u_far = cells_to_far_side(axes_, sat, centre[axes_.m]);
    double depth = 0;
    for (const Entry& e : entries_) {
      if (e.u0 >= u_far) break;
      if (e.u1 > u_far) {  // the last slab, cut at the grid's far side
        const CellBox box = slab_box(axes_, centre, e.u0, u_far);
        depth += sat.sum(box) / static_cast<double>(box.count()) * ((u_far - e.u0) * cell_m_ / axes_.lm);
        break;
      }
      CellBox box;
      for (int a = 0; a < 3; ++a) {
        box.lo[a] = e.box.lo[a] + c[a];
        box.hi[a] = e.box.hi[a] + c[a];
      }
      depth += sat.sum(box) * e.weight;
      if (depth >= kOpaqueDepth) break;
    }
    return depth;
  }

private:
  struct Entry {
    CellBox box;    // relative to the apex cell
    double weight;  // path length / cell count
    float u0, u1;   // the slab, cells from the apex along the main axis
  };
  ConeAxes axes_;
  float cell_m_ = 1;
  std::vector<Entry> entries_;
};

}  // namespace penumbra
