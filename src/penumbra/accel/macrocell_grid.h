// Min/max macrocell grid for empty-space skipping: the volume is cut into cells of kCellSize^3 voxels;
// each cell keeps the smallest and largest value its trilinear interpolant can take (the voxels it
// touches, one voxel of overlap). Given a transfer function, a cell is empty when no value in its
// range has non-zero opacity — then a ray may jump to the cell's far side without sampling.
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/data/transfer_function.h"
#include "penumbra/data/volume.h"

namespace penumbra {

class MacrocellGrid {
public:
  static constexpr int kCellSize = 8;

  MacrocellGrid() = default;
  explicit MacrocellGrid(const Volume& volume);  // min/max pass, independent of the transfer function

  // Marks the cells whose value range is invisible under `lut` (cheap: one O(1) query per cell).
  std::vector<std::uint8_t> empty_cells(const TransferLut& lut) const;

  const std::array<int, 3>& cells() const { return cells_; }
  std::size_t cell_index(int cx, int cy, int cz) const {
    return (static_cast<std::size_t>(cz) * cells_[1] + cy) * cells_[0] + cx;
  }
  std::size_t memory_bytes() const { return range_.size() * sizeof(range_[0]); }

private:
  std::array<int, 3> cells_{0, 0, 0};
  std::vector<std::array<float, 2>> range_;
};

// Walks a ray through a volume's samples, skipping empty macrocells. Sample k sits at t = k * step
// along the ray (a global lattice, so positions do not depend on where the walk started).
class EmptySpaceSkipper {
public:
  EmptySpaceSkipper(const Volume& volume, const MacrocellGrid& grid, const std::vector<std::uint8_t>& empty)
      : volume_(&volume), grid_(&grid), empty_(&empty) {}

  // If the sample at world position p lies in an empty cell, returns the ray parameter where the ray
  // leaves that cell (> t); otherwise returns t.
  float skip(const Ray& r, float t, const Vec3& p) const {
    const Vec3 v = volume_->to_voxel(p);
    const auto& c = grid_->cells();
    const int cx = std::clamp(static_cast<int>(v.x) / MacrocellGrid::kCellSize, 0, c[0] - 1);
    const int cy = std::clamp(static_cast<int>(v.y) / MacrocellGrid::kCellSize, 0, c[1] - 1);
    const int cz = std::clamp(static_cast<int>(v.z) / MacrocellGrid::kCellSize, 0, c[2] - 1);
    if (!(*empty_)[grid_->cell_index(cx, cy, cz)]) return t;
    // exit of the cell box (in world units)
    const Vec3& s = volume_->spacing();
    const Vec3& o = volume_->origin();
    const float k = static_cast<float>(MacrocellGrid::kCellSize);
    Box3 cell{{o.x + static_cast<float>(cx) * k * s.x, o.y + static_cast<float>(cy) * k * s.y, o.z + static_cast<float>(cz) * k * s.z},
              {o.x + static_cast<float>(cx + 1) * k * s.x, o.y + static_cast<float>(cy + 1) * k * s.y,
               o.z + static_cast<float>(cz + 1) * k * s.z}};
    float t0, t1;
    if (!cell.clip(r, t0, t1, t, kInfinity)) return t;
    return std::max(t, t1);
  }

private:
  const Volume* volume_;
  const MacrocellGrid* grid_;
  const std::vector<std::uint8_t>* empty_;
};

}  // namespace penumbra
