// The min/max hierarchy of paper 002 §3.1.1 (the GridTree of PIsA: nested grids): built once per
// volume and valid for every isovalue. Level 0 cuts the volume's cells (the 2x2x2-voxel cubes of the
// trilinear interpolant) into bricks of kBrickCells^3 cells; each level above groups 2x2x2 nodes of the
// level below, up to a single root. Every node keeps the smallest and largest voxel its cells touch, so
// a node whose range does not straddle the isovalue (range_straddles) holds no surface and is pruned
// with all its children.
#pragma once

#include <array>
#include <cstddef>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/data/volume.h"
#include "penumbra/geometry/iso_point.h"

namespace penumbra {

class GridTree {
public:
  static constexpr int kBrickCells = 4;

  // Throws Error when the volume has fewer than 2 voxels along an axis (no cells).
  explicit GridTree(const Volume& volume);

  const Volume& volume() const { return *volume_; }
  const std::array<int, 3>& cells() const { return cells_; }  // cells per axis: dims - 1
  int levels() const { return static_cast<int>(levels_.size()); }
  const std::array<int, 3>& level_dims(int level) const { return levels_[static_cast<std::size_t>(level)].dims; }
  // Cells along each side of a node at `level` (the last node along an axis may hold fewer).
  int node_cells(int level) const { return kBrickCells << level; }

  // (min, max) of the voxels touched by node (i, j, k) of `level`.
  const std::array<float, 2>& range(int level, int i, int j, int k) const {
    const Level& l = levels_[static_cast<std::size_t>(level)];
    return l.range[(static_cast<std::size_t>(k) * l.dims[1] + j) * l.dims[0] + i];
  }
  bool may_contain(int level, int i, int j, int k, float isovalue) const {
    const auto& r = range(level, i, j, k);
    return range_straddles(r[0], r[1], isovalue);
  }
  // Cells [lo, hi) covered by node (i, j, k) of `level`, clipped to the grid.
  void node_cells(int level, int i, int j, int k, std::array<int, 3>& lo, std::array<int, 3>& hi) const;
  // World box of cells [lo, hi).
  Box3 cell_box(const std::array<int, 3>& lo, const std::array<int, 3>& hi) const;

  std::size_t memory_bytes() const;
  double build_ms() const { return build_ms_; }

private:
  struct Level {
    std::array<int, 3> dims;
    std::vector<std::array<float, 2>> range;
  };
  const Volume* volume_;
  std::array<int, 3> cells_;
  std::vector<Level> levels_;  // [0] bricks ... back() the root
  double build_ms_ = 0;
};

}  // namespace penumbra
