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

#include "penumbra/accel/extinction_sat.h"

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

// Optical depth at which a cone stops: transmittance below 1e-4 (OSPRay's minContribution).
constexpr double kOpaqueDepth = 9.21;

// Visits the cuboids from the apex outwards; visit(const ConeCuboid&) returns false to stop.
// `to_light`: unit direction; `distance`: to the light (infinity for directional lights).
template <class Visit>
void for_each_cone_cuboid(const ExtinctionSat& sat, const Vec3& apex, const Vec3& to_light, float distance,
                          const ConeSampling& s, Visit&& visit) {
  int m = 0;
  for (int a = 1; a < 3; ++a)
    if (std::abs(to_light[a]) > std::abs(to_light[m])) m = a;
  const float lm = std::abs(to_light[m]);
  if (!(lm > 0)) return;
  const int sign = to_light[m] > 0 ? 1 : -1;
  const Vec3 cell = sat.cell_size();
  const Vec3 c = sat.to_cell(apex);  // continuous cell coordinates
  const auto& dims = sat.dims();

  // Wedge slopes (world units across per world unit along m) on the two secondary axes.
  const float sin_theta = std::sin(s.half_angle);
  constexpr float kMaxSlope = 57.0f;  // tan 89°: a wedge reaching 90° is clamped there
  int sec[2];
  float slope_lo[2], slope_hi[2];
  for (int q = 0, a = 0; a < 3; ++a) {
    if (a == m) continue;
    sec[q] = a;
    const float t0 = to_light[a] / lm;  // tan φ₀
    const float ca2 = lm * lm + to_light[a] * to_light[a];
    float lo = -kMaxSlope, hi = kMaxSlope;
    if (sin_theta * sin_theta < ca2) {
      const float td = sin_theta / std::sqrt(ca2 - sin_theta * sin_theta);  // tan δ
      const float den_hi = 1 - t0 * td, den_lo = 1 + t0 * td;
      hi = den_hi > 1.0f / kMaxSlope ? std::min((t0 + td) / den_hi, kMaxSlope) : kMaxSlope;
      lo = den_lo > 1.0f / kMaxSlope ? std::max((t0 - td) / den_lo, -kMaxSlope) : -kMaxSlope;
    }
    slope_lo[q] = lo;
    slope_hi[q] = hi;
    ++q;
  }

  // Main-axis extent in cell planes: from the apex to the light or the grid's far side.
  const float cell_m = cell[m];
  const float u_light = distance < kInfinity ? distance * lm / cell_m : kInfinity;  // cells along m
  const float u_grid = sign > 0 ? static_cast<float>(dims[m]) - c[m] : c[m];
  const float u_end = std::min(u_light, u_grid);
  if (!(u_end > 0)) return;
  const float base = std::max(1.0f, static_cast<float>(std::max(dims[0], std::max(dims[1], dims[2]))) / s.samples_per_unit);

  // Distance (cells along m) from the apex to the first cell plane past it, in (0, 1].
  const float first = sign > 0 ? std::floor(c[m]) + 1 - c[m] : c[m] - (std::ceil(c[m]) - 1);
  float u0 = 0, u1 = std::min(first, u_end);  // the slab [u0, u1], cells from the apex along m
  double target = 0;                          // unrounded planes past `first` so far
  int planes = 0;
  float thickness = base;
  while (true) {
    ConeCuboid q;
    const float m_lo = sign > 0 ? c[m] + u0 : c[m] - u1, m_hi = sign > 0 ? c[m] + u1 : c[m] - u0;
    q.box.lo[m] = static_cast<int>(std::floor(m_lo + 1e-4f));
    q.box.hi[m] = std::max(q.box.lo[m] + 1, static_cast<int>(std::ceil(m_hi - 1e-4f)));
    const float um = 0.5f * (u0 + u1) * cell_m;  // the slab's mid-plane, world units along m
    for (int k = 0; k < 2; ++k) {
      const int a = sec[k];
      q.box.lo[a] = static_cast<int>(std::floor(c[a] + um * slope_lo[k] / cell[a]));
      q.box.hi[a] = static_cast<int>(std::floor(c[a] + um * slope_hi[k] / cell[a])) + 1;
    }
    q.path_length = (u1 - u0) * cell_m / lm;
    if (!visit(q) || u1 >= u_end) return;
    target += thickness;
    thickness *= 1 + s.growth;
    planes = std::max(planes + 1, static_cast<int>(std::lround(target)));
    u0 = u1;
    u1 = std::min(first + static_cast<float>(planes), u_end);
  }
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

}  // namespace penumbra
