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

// The empty-space queries a ray march makes: which cell holds a sample, is it empty, and where does the
// ray leave it. Callers check emptiness only when a sample enters a new cell.
class EmptySpaceSkipper {
public:
  EmptySpaceSkipper(const Volume& volume, const MacrocellGrid& grid, const std::vector<std::uint8_t>& empty)
      : volume_(&volume), grid_(&grid), empty_(&empty) {}

  // Cell of continuous voxel coordinates v (clamped to the grid).
  std::size_t cell_of(const Vec3& v) const {
    const auto& c = grid_->cells();
    return grid_->cell_index(std::clamp(static_cast<int>(v.x) / MacrocellGrid::kCellSize, 0, c[0] - 1),
                             std::clamp(static_cast<int>(v.y) / MacrocellGrid::kCellSize, 0, c[1] - 1),
                             std::clamp(static_cast<int>(v.z) / MacrocellGrid::kCellSize, 0, c[2] - 1));
  }
  // The same cell found from the trilinear cell a sample reads (its lower corner's integers: no
  // float conversions again).
  std::size_t cell_of(const TrilinearCell& c) const {
    constexpr unsigned n = MacrocellGrid::kCellSize;
    return grid_->cell_index(static_cast<int>(static_cast<unsigned>(c.i) / n), static_cast<int>(static_cast<unsigned>(c.j) / n),
                             static_cast<int>(static_cast<unsigned>(c.k) / n));
  }
  bool empty(std::size_t cell) const { return (*empty_)[cell] != 0; }

  // Ray parameter (>= t) where r leaves the cell that holds voxel coordinates v.
  float cell_exit(const Ray& r, float t, const Vec3& v) const {
    const auto& c = grid_->cells();
    const int cell[3] = {std::clamp(static_cast<int>(v.x) / MacrocellGrid::kCellSize, 0, c[0] - 1),
                         std::clamp(static_cast<int>(v.y) / MacrocellGrid::kCellSize, 0, c[1] - 1),
                         std::clamp(static_cast<int>(v.z) / MacrocellGrid::kCellSize, 0, c[2] - 1)};
    const Vec3& s = volume_->spacing();
    const Vec3& o = volume_->origin();
    const float k = static_cast<float>(MacrocellGrid::kCellSize);
    Box3 box;
    for (int a = 0; a < 3; ++a) {
      box.lo[a] = o[a] + static_cast<float>(cell[a]) * k * s[a];
      box.hi[a] = o[a] + static_cast<float>(cell[a] + 1) * k * s[a];
    }
    float t0, t1;
    if (!box.clip(r, t0, t1, t, kInfinity)) return t;
    return std::max(t, t1);
  }

private:
  const Volume* volume_;
  const MacrocellGrid* grid_;
  const std::vector<std::uint8_t>* empty_;
};

}  // namespace penumbra
