#include "penumbra/data/selection/neighbor_grid.h"

#include <algorithm>
#include <cmath>

#include "penumbra/core/parallel.h"

namespace penumbra {
namespace {

// The references binned: cell c holds order[start[c] .. start[c + 1]) (indices into `placed`, the
// references as the grid sees them: wrapped into the cell, or as given).
struct GridBins {
  int n[3] = {1, 1, 1};
  std::vector<std::uint32_t> start, order;
  std::vector<Vec3> placed;
  int index(int x, int y, int z) const { return (z * n[1] + y) * n[0] + x; }
};

// Cells per axis: as many as fit with width ≥ cutoff, at most about 2 per reference in all.
void size_grid(GridBins& bins, const float width[3], float cutoff, std::size_t references) {
  const double limit = 2.0 * static_cast<double>(references) + 27;
  double scale = 1;
  for (;;) {
    double total = 1;
    for (int i = 0; i < 3; ++i) {
      const double cells = cutoff > 0 ? std::floor(width[i] / (cutoff * scale)) : 1e9;
      bins.n[i] = static_cast<int>(std::clamp(cells, 1.0, 1024.0));
      total *= bins.n[i];
    }
    if (total <= limit) return;
    scale *= 1.25;
  }
}

void fill_bins(GridBins& bins, const std::vector<int>& cell_of) {
  const std::size_t cells = static_cast<std::size_t>(bins.n[0]) * bins.n[1] * bins.n[2];
  bins.start.assign(cells + 1, 0);
  for (const int c : cell_of) ++bins.start[static_cast<std::size_t>(c) + 1];
  for (std::size_t c = 0; c < cells; ++c) bins.start[c + 1] += bins.start[c];
  bins.order.resize(cell_of.size());
  std::vector<std::uint32_t> next(bins.start.begin(), bins.start.end() - 1);
  for (std::size_t i = 0; i < cell_of.size(); ++i) bins.order[next[static_cast<std::size_t>(cell_of[i])]++] = static_cast<std::uint32_t>(i);
}

int floor_cell(float f, int n) { return static_cast<int>(std::floor(f * static_cast<float>(n))); }

float wrapped(float f) { return f - std::floor(f); }

// Without a box the grid spans the references' bounds, but at least the cutoff along each axis, so a
// cell is never narrower than the cutoff.
float axis_width(const Box3& bounds, int axis, float cutoff) {
  return std::max({bounds.hi[axis] - bounds.lo[axis], cutoff, 1e-6f});
}

}  // namespace

std::vector<std::uint8_t> points_near(const std::vector<Vec3>& references, const std::vector<Vec3>& points,
                                      const std::vector<std::uint8_t>& test, float cutoff,
                                      const std::optional<PeriodicCell>& cell) {
  std::vector<std::uint8_t> near(points.size(), 0);
  if (references.empty()) return near;
  const float cutoff2 = cutoff * cutoff;
  GridBins bins;
  std::vector<int> cell_of(references.size());
  bins.placed.resize(references.size());
  Box3 bounds;
  if (cell) {
    size_grid(bins, cell->width, cutoff, references.size());
    for (std::size_t i = 0; i < references.size(); ++i) {
      Vec3 f = cell->fractional(references[i]);
      f = Vec3{wrapped(f.x), wrapped(f.y), wrapped(f.z)};
      bins.placed[i] = cell->cartesian(f);
      cell_of[i] = bins.index(std::min(floor_cell(f.x, bins.n[0]), bins.n[0] - 1), std::min(floor_cell(f.y, bins.n[1]), bins.n[1] - 1),
                              std::min(floor_cell(f.z, bins.n[2]), bins.n[2] - 1));
    }
  } else {
    for (const Vec3& r : references) bounds.extend(r);
    const float width[3] = {axis_width(bounds, 0, cutoff), axis_width(bounds, 1, cutoff), axis_width(bounds, 2, cutoff)};
    size_grid(bins, width, cutoff, references.size());
    for (std::size_t i = 0; i < references.size(); ++i) {
      bins.placed[i] = references[i];
      int c[3];
      for (int a = 0; a < 3; ++a)
        c[a] = std::clamp(floor_cell((references[i][a] - bounds.lo[a]) / width[a], bins.n[a]), 0, bins.n[a] - 1);
      cell_of[i] = bins.index(c[0], c[1], c[2]);
    }
  }
  fill_bins(bins, cell_of);

  parallel_for(points.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      if (!test[i]) continue;
      Vec3 p = points[i];
      int home[3];
      if (cell) {
        Vec3 f = cell->fractional(p);
        f = Vec3{wrapped(f.x), wrapped(f.y), wrapped(f.z)};
        p = cell->cartesian(f);
        for (int a = 0; a < 3; ++a) home[a] = std::min(floor_cell(f[a], bins.n[a]), bins.n[a] - 1);
      } else {
        for (int a = 0; a < 3; ++a) {
          const float f = (p[a] - bounds.lo[a]) / axis_width(bounds, a, cutoff);
          home[a] = f < -1 ? -2 : f > 2 ? bins.n[a] + 1 : floor_cell(f, bins.n[a]);  // far outside: no neighbour cell
        }
      }
      bool found = false;
      for (int dz = -1; dz <= 1 && !found; ++dz)
        for (int dy = -1; dy <= 1 && !found; ++dy)
          for (int dx = -1; dx <= 1 && !found; ++dx) {
            int c[3] = {home[0] + dx, home[1] + dy, home[2] + dz};
            Vec3 shift{};
            bool inside = true;
            for (int a = 0; a < 3; ++a) {
              if (cell) {
                const int wraps = c[a] < 0 ? -1 : c[a] >= bins.n[a] ? 1 : 0;  // the image this cell stands for
                c[a] -= wraps * bins.n[a];
                const Vec3 axis = a == 0 ? cell->a : a == 1 ? cell->b : cell->c;
                shift += axis * static_cast<float>(wraps);
              } else if (c[a] < 0 || c[a] >= bins.n[a]) {
                inside = false;
              }
            }
            if (!inside) continue;
            const int k = bins.index(c[0], c[1], c[2]);
            for (std::uint32_t s = bins.start[static_cast<std::size_t>(k)]; s < bins.start[static_cast<std::size_t>(k) + 1]; ++s) {
              const Vec3 d = bins.placed[bins.order[s]] + shift - p;
              if (dot(d, d) <= cutoff2) {
                found = true;
                break;
              }
            }
          }
      near[i] = found ? 1 : 0;
    }
  }, 2048);
  return near;
}

}  // namespace penumbra
