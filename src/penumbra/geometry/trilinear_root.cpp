#include "penumbra/geometry/trilinear_root.h"

#include <algorithm>
#include <cmath>

namespace penumbra {

namespace {

// g(s) = f(ray.at(t0 + s)) - isovalue = c[0] + c[1] s + c[2] s^2 + c[3] s^3 (Marmitt et al. 2004, Eq. 3).
struct Cubic {
  std::array<double, 4> c{};
  double operator()(double s) const { return c[0] + s * (c[1] + s * (c[2] + s * c[3])); }
};

using Poly = std::array<double, 4>;  // coefficients of 1, s, s^2, s^3

// a + (b - a) * (w + dw s): one axis of the trilinear interpolation with its weight linear in s.
// Interpolating x, then y, then z raises the degree by one each time, to the cubic.
Poly lerp(const Poly& a, const Poly& b, double w, double dw) {
  Poly r;
  for (std::size_t n = 0; n < 4; ++n) {
    const double d = b[n] - a[n];
    const double d_prev = n > 0 ? b[n - 1] - a[n - 1] : 0.0;
    r[n] = a[n] + w * d + dw * d_prev;
  }
  return r;
}

Cubic cell_cubic(const CornerValues& v, const std::array<int, 3>& cell, float isovalue, const GridRay& ray, float t0) {
  std::array<double, 3> w;  // the segment's start in the cell's local coordinates, [0, 1]^3 inside it
  for (std::size_t a = 0; a < 3; ++a) w[a] = ray.origin[a] + ray.direction[a] * t0 - cell[a];
  const auto& d = ray.direction;
  std::array<Poly, 4> along_x;  // for each (j, k): the interpolant along x, degree 1
  for (std::size_t jk = 0; jk < 4; ++jk)
    along_x[jk] = lerp({v[2 * jk], 0, 0, 0}, {v[2 * jk + 1], 0, 0, 0}, w[0], d[0]);
  const Poly y0 = lerp(along_x[0], along_x[1], w[1], d[1]);
  const Poly y1 = lerp(along_x[2], along_x[3], w[1], d[1]);
  Cubic g{lerp(y0, y1, w[2], d[2])};
  g.c[0] -= isovalue;
  return g;
}

// Parameters in (0, length) where g' = c1 + 2 c2 s + 3 c3 s^2 vanishes, ascending: the ends of g's
// monotone pieces. The quadratic's roots by the cancellation-free form (q = -(b ± sqrt(disc)) / 2).
int turning_points(const Cubic& g, double length, std::array<double, 2>& out) {
  const double a = 3 * g.c[3], b = 2 * g.c[2], c = g.c[1];
  std::array<double, 2> r;
  int n = 0;
  if (a == 0) {
    if (b != 0) r[n++] = -c / b;
  } else {
    const double disc = b * b - 4 * a * c;
    if (disc >= 0) {
      const double q = -0.5 * (b + std::copysign(std::sqrt(disc), b));
      r[n++] = q / a;
      if (q != 0) r[n++] = c / q;
    }
  }
  int kept = 0;
  for (int i = 0; i < n; ++i)
    if (r[static_cast<std::size_t>(i)] > 0 && r[static_cast<std::size_t>(i)] < length) out[static_cast<std::size_t>(kept++)] = r[static_cast<std::size_t>(i)];
  if (kept == 2 && out[0] > out[1]) std::swap(out[0], out[1]);
  return kept;
}

// On a piece [lo, hi] where g is monotone, inside(lo) == start_inside and inside(hi) != start_inside:
// the first parameter whose state differs, to float precision of t = t0 + s. Regula falsi with the
// Illinois modification (each end moves, so the bracket closes superlinearly), bisection as fallback.
double refine(const Cubic& g, double lo, double hi, bool start_inside, float t0) {
  double glo = g(lo), ghi = g(hi);
  int last_moved = 0;  // -1: lo moved last, +1: hi moved last
  for (int it = 0; it < 100; ++it) {
    if (static_cast<float>(t0 + lo) == static_cast<float>(t0 + hi)) break;
    double x = glo != ghi ? lo - glo * (hi - lo) / (ghi - glo) : 0.5 * (lo + hi);
    if (!(x > lo && x < hi)) x = 0.5 * (lo + hi);
    if (!(x > lo && x < hi)) break;  // lo and hi are adjacent doubles
    const double gx = g(x);
    if ((gx >= 0) == start_inside) {
      lo = x;
      glo = gx;
      if (last_moved == -1) ghi *= 0.5;
      last_moved = -1;
    } else {
      hi = x;
      ghi = gx;
      if (last_moved == 1) glo *= 0.5;
      last_moved = 1;
    }
  }
  return hi;
}

float first_change(const Cubic& g, float t0, float t1, bool inside_before) {
  if ((g(0) >= 0) != inside_before) return t0;
  const double length = static_cast<double>(t1) - static_cast<double>(t0);
  if (!(length > 0)) return kInfinity;
  std::array<double, 2> turns;
  const int n = turning_points(g, length, turns);
  double lo = 0;
  for (int piece = 0; piece <= n; ++piece) {
    const double hi = piece < n ? turns[static_cast<std::size_t>(piece)] : length;
    // g is monotone on [lo, hi] and inside(lo) == inside_before: the state changes in the piece iff
    // it differs at hi.
    if ((g(hi) >= 0) != inside_before) {
      const float t = static_cast<float>(t0 + refine(g, lo, hi, inside_before, t0));
      return std::min(t, t1);
    }
    lo = hi;
  }
  return kInfinity;
}

CornerValues fetch_corners(const Volume& volume, const std::array<int, 3>& cell) {
  CornerValues v;
  for (int n = 0; n < 8; ++n)
    v[static_cast<std::size_t>(n)] = volume.value(cell[0] + (n & 1), cell[1] + ((n >> 1) & 1), cell[2] + (n >> 2));
  return v;
}

}  // namespace

GridRay::GridRay(const Volume& volume, const Ray& ray) {
  const Vec3& o = volume.origin();
  const Vec3& s = volume.spacing();
  for (int a = 0; a < 3; ++a) {
    origin[static_cast<std::size_t>(a)] = (static_cast<double>(ray.origin[a]) - o[a]) / s[a];
    direction[static_cast<std::size_t>(a)] = static_cast<double>(ray.direction[a]) / s[a];
  }
}

bool inside_at(const CornerValues& corners, const std::array<int, 3>& cell, float isovalue, const GridRay& ray, float t) {
  return cell_cubic(corners, cell, isovalue, ray, t)(0) >= 0;
}

float first_state_change(const CornerValues& corners, const std::array<int, 3>& cell, float isovalue,
                         const GridRay& ray, float t0, float t1, bool inside_before) {
  return first_change(cell_cubic(corners, cell, isovalue, ray, t0), t0, t1, inside_before);
}

float first_crossing_in_cell(const Volume& volume, const std::array<int, 3>& cell, float isovalue, const Ray& ray,
                             float t0, float t1) {
  const Cubic g = cell_cubic(fetch_corners(volume, cell), cell, isovalue, GridRay(volume, ray), t0);
  return first_change(g, t0, t1, g(0) >= 0);
}

}  // namespace penumbra
