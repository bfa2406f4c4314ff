#include "penumbra/data/selection/neighbor_grid.h"

#include <algorithm>
#include <atomic>
#include <cmath>

#include "penumbra/core/parallel.h"

namespace penumbra {
namespace {

float wrapped(float f) { return f - std::floor(f); }
int floor_cell(float f, int n) { return static_cast<int>(std::floor(f * static_cast<float>(n))); }

// Without a box the grid spans the binned atoms' bounds, but at least the cutoff along each axis, so a
// cell is never narrower than the cutoff.
float axis_width(const Box3& bounds, int axis, float cutoff) {
  return std::max({bounds.hi[axis] - bounds.lo[axis], cutoff, 1e-6f});
}

// Atoms binned by cell: cell c holds order[start[c] .. start[c + 1]) (indices of atoms), each at
// placed[k] for its k-th position in `order` (wrapped into the cell, or as given).
class AtomGrid {
public:
  AtomGrid(const std::vector<Vec3>& positions, const std::vector<std::uint32_t>& members, float cutoff,
           const std::optional<PeriodicCell>& cell)
      : cell_(cell), cutoff2_(cutoff * cutoff) {
    std::vector<int> cell_of(members.size());
    std::vector<Vec3> placed(members.size());
    if (cell) {
      size_grid(cell->width, cutoff, members.size());
      for (std::size_t k = 0; k < members.size(); ++k) {
        int c[3];
        placed[k] = locate(positions[members[k]], c);
        cell_of[k] = index(c[0], c[1], c[2]);
      }
    } else {
      for (const std::uint32_t m : members) bounds_.extend(positions[m]);
      for (int a = 0; a < 3; ++a) width_[a] = axis_width(bounds_, a, cutoff);
      size_grid(width_, cutoff, members.size());
      for (std::size_t k = 0; k < members.size(); ++k) {
        int c[3];
        placed[k] = locate(positions[members[k]], c);
        for (int a = 0; a < 3; ++a) c[a] = std::clamp(c[a], 0, n_[a] - 1);
        cell_of[k] = index(c[0], c[1], c[2]);
      }
    }
    // counting sort by cell
    const std::size_t cells = static_cast<std::size_t>(n_[0]) * n_[1] * n_[2];
    start_.assign(cells + 1, 0);
    for (const int c : cell_of) ++start_[static_cast<std::size_t>(c) + 1];
    for (std::size_t c = 0; c < cells; ++c) start_[c + 1] += start_[c];
    atoms_.resize(members.size());
    placed_.resize(members.size());
    std::vector<std::uint32_t> next(start_.begin(), start_.end() - 1);
    for (std::size_t k = 0; k < members.size(); ++k) {
      const std::uint32_t slot = next[static_cast<std::size_t>(cell_of[k])]++;
      atoms_[slot] = members[k];
      placed_[slot] = placed[k];
    }
  }

  // Calls visit(atom) for binned atoms within the cutoff of p until it returns true; whether it did.
  template <class Visit>
  bool any_near(Vec3 p, Visit visit) const {
    int home[3];
    p = locate(p, home);
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          int c[3] = {home[0] + dx, home[1] + dy, home[2] + dz};
          Vec3 shift{};
          bool inside = true;
          for (int a = 0; a < 3; ++a) {
            if (cell_) {
              const int wraps = c[a] < 0 ? -1 : c[a] >= n_[a] ? 1 : 0;  // the image this cell stands for
              c[a] -= wraps * n_[a];
              if (wraps != 0) shift += (a == 0 ? cell_->a : a == 1 ? cell_->b : cell_->c) * static_cast<float>(wraps);
            } else if (c[a] < 0 || c[a] >= n_[a]) {
              inside = false;
            }
          }
          if (!inside) continue;
          const auto k = static_cast<std::size_t>(index(c[0], c[1], c[2]));
          for (std::uint32_t s = start_[k]; s < start_[k + 1]; ++s) {
            const Vec3 d = placed_[s] + shift - p;
            if (dot(d, d) <= cutoff2_ && visit(atoms_[s])) return true;
          }
        }
    return false;
  }

private:
  std::optional<PeriodicCell> cell_;
  float cutoff2_;
  Box3 bounds_;
  float width_[3] = {1, 1, 1};
  int n_[3] = {1, 1, 1};
  std::vector<std::uint32_t> start_, atoms_;
  std::vector<Vec3> placed_;

  int index(int x, int y, int z) const { return (z * n_[1] + y) * n_[0] + x; }

  // Cells per axis: as many as fit with width ≥ cutoff, at most about 2 per binned atom in all.
  void size_grid(const float width[3], float cutoff, std::size_t atoms) {
    const double limit = 2.0 * static_cast<double>(atoms) + 27;
    for (double scale = 1;; scale *= 1.25) {
      double total = 1;
      for (int i = 0; i < 3; ++i) {
        const double cells = cutoff > 0 ? std::floor(width[i] / (cutoff * scale)) : 1e9;
        n_[i] = static_cast<int>(std::clamp(cells, 1.0, 1024.0));
        total *= n_[i];
      }
      if (total <= limit) return;
    }
  }

  // p as the grid sees it (wrapped into the cell, or as given) and its cell (periodic: within the
  // grid; otherwise possibly outside it, -2 or n + 1 when far outside).
  Vec3 locate(Vec3 p, int c[3]) const {
    if (cell_) {
      Vec3 f = cell_->fractional(p);
      f = Vec3{wrapped(f.x), wrapped(f.y), wrapped(f.z)};
      for (int a = 0; a < 3; ++a) c[a] = std::min(floor_cell(f[a], n_[a]), n_[a] - 1);
      return cell_->cartesian(f);
    }
    for (int a = 0; a < 3; ++a) {
      const float f = (p[a] - bounds_.lo[a]) / width_[a];
      c[a] = f < -1 ? -2 : f > 2 ? n_[a] + 1 : floor_cell(f, n_[a]);
    }
    return p;
  }
};

std::vector<std::uint32_t> members_of(const std::vector<std::uint8_t>& mask) {
  std::vector<std::uint32_t> m;
  for (std::size_t i = 0; i < mask.size(); ++i)
    if (mask[i]) m.push_back(static_cast<std::uint32_t>(i));
  return m;
}

}  // namespace

std::vector<std::uint8_t> points_near(const std::vector<Vec3>& positions, const std::vector<std::uint8_t>& reference,
                                      const std::vector<std::uint8_t>& test, float cutoff,
                                      const std::optional<PeriodicCell>& cell) {
  std::vector<std::uint8_t> near(positions.size(), 0);
  const std::vector<std::uint32_t> refs = members_of(reference), tested = members_of(test);
  if (refs.empty() || tested.empty()) return near;
  if (refs.size() <= tested.size()) {  // bin the tested atoms, walk the references
    const AtomGrid grid(positions, tested, cutoff, cell);
    parallel_for(refs.size(), [&](std::size_t begin, std::size_t end) {
      for (std::size_t r = begin; r < end; ++r)
        grid.any_near(positions[refs[r]], [&](std::uint32_t j) {
          std::atomic_ref<std::uint8_t>(near[j]).store(1, std::memory_order_relaxed);
          return false;
        });
    }, 256);
  } else {  // bin the references, walk the tested atoms (each stops at its first hit)
    const AtomGrid grid(positions, refs, cutoff, cell);
    parallel_for(tested.size(), [&](std::size_t begin, std::size_t end) {
      for (std::size_t t = begin; t < end; ++t)
        near[tested[t]] = grid.any_near(positions[tested[t]], [](std::uint32_t) { return true; }) ? 1 : 0;
    }, 2048);
  }
  return near;
}

}  // namespace penumbra
