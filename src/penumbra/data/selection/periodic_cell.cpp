#include "penumbra/data/selection/periodic_cell.h"

#include <algorithm>
#include <cmath>

namespace penumbra {

std::optional<PeriodicCell> periodic_cell(const std::optional<CellDimensions>& dimensions) {
  if (!dimensions) return std::nullopt;
  const auto& d = *dimensions;
  if (!(d[0] > 0 && d[1] > 0 && d[2] > 0 && d[3] > 0 && d[4] > 0 && d[5] > 0 && d[3] < 180 && d[4] < 180 && d[5] < 180))
    return std::nullopt;
  const double rad = 3.14159265358979323846 / 180.0;
  const double ca = std::cos(d[3] * rad), cb = std::cos(d[4] * rad), cg = std::cos(d[5] * rad), sg = std::sin(d[5] * rad);
  const double cx = cb, cy = (ca - cb * cg) / sg, cz2 = 1 - cx * cx - cy * cy;
  if (!(cz2 > 0)) return std::nullopt;
  PeriodicCell cell;
  cell.a = Vec3{d[0], 0, 0};
  cell.b = Vec3{static_cast<float>(d[1] * cg), static_cast<float>(d[1] * sg), 0};
  cell.c = Vec3{static_cast<float>(d[2] * cx), static_cast<float>(d[2] * cy), static_cast<float>(d[2] * std::sqrt(cz2))};
  const Vec3 bc = cross(cell.b, cell.c), ca_ = cross(cell.c, cell.a), ab = cross(cell.a, cell.b);
  const float volume = dot(cell.a, bc);
  cell.inverse_rows[0] = bc * (1 / volume);
  cell.inverse_rows[1] = ca_ * (1 / volume);
  cell.inverse_rows[2] = ab * (1 / volume);
  cell.width[0] = volume / length(bc);
  cell.width[1] = volume / length(ca_);
  cell.width[2] = volume / length(ab);
  return cell;
}

float PeriodicCell::minimum_image_length2(Vec3 d) const {
  Vec3 f = fractional(d);
  f = Vec3{f.x - std::round(f.x), f.y - std::round(f.y), f.z - std::round(f.z)};
  const Vec3 base = cartesian(f);
  float best = dot(base, base);
  for (int i = -1; i <= 1; ++i)  // a skewed cell's shortest image may be a neighbour of the rounded one
    for (int j = -1; j <= 1; ++j)
      for (int k = -1; k <= 1; ++k) {
        const Vec3 v = base + a * static_cast<float>(i) + b * static_cast<float>(j) + c * static_cast<float>(k);
        best = std::min(best, dot(v, v));
      }
  return best;
}

}  // namespace penumbra
