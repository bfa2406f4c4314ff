#include "penumbra/accel/macrocell_grid.h"

#include "penumbra/core/parallel.h"

namespace penumbra {

MacrocellGrid::MacrocellGrid(const Volume& volume) {
  const auto& d = volume.dims();
  for (int a = 0; a < 3; ++a) cells_[a] = std::max(1, (d[a] - 1 + kCellSize - 1) / kCellSize);
  range_.assign(static_cast<std::size_t>(cells_[0]) * cells_[1] * cells_[2], {0, 0});
  parallel_for(static_cast<std::size_t>(cells_[2]), [&](std::size_t z0, std::size_t z1) {
    for (std::size_t cz = z0; cz < z1; ++cz)
      for (int cy = 0; cy < cells_[1]; ++cy)
        for (int cx = 0; cx < cells_[0]; ++cx) {
          static_assert(kCellSize == Volume::kBrickCells, "a macrocell is a brick of a bricked volume");
          if (volume.is_bricked() && volume.brick_is_shared(cx, cy, static_cast<int>(cz))) {
            const float v = volume.value(volume.brick_base(cx, cy, static_cast<int>(cz)));
            range_[cell_index(cx, cy, static_cast<int>(cz))] = {v, v};
            continue;
          }
          float lo = kInfinity, hi = -kInfinity;
          // voxels [c*K, (c+1)*K] inclusive: the interpolant inside the cell touches both ends
          const int k0 = static_cast<int>(cz) * kCellSize, k1 = std::min(d[2] - 1, k0 + kCellSize);
          const int j0 = cy * kCellSize, j1 = std::min(d[1] - 1, j0 + kCellSize);
          const int i0 = cx * kCellSize, i1 = std::min(d[0] - 1, i0 + kCellSize);
          for (int k = k0; k <= k1; ++k)
            for (int j = j0; j <= j1; ++j)
              for (int i = i0; i <= i1; ++i) {
                const float v = volume.value(i, j, k);
                lo = std::min(lo, v);
                hi = std::max(hi, v);
              }
          range_[cell_index(cx, cy, static_cast<int>(cz))] = {lo, hi};
        }
  });
}

std::vector<std::uint8_t> MacrocellGrid::empty_cells(const TransferLut& lut) const {
  std::vector<std::uint8_t> empty(range_.size());
  for (std::size_t i = 0; i < range_.size(); ++i) empty[i] = lut.any_visible(range_[i][0], range_[i][1]) ? 0 : 1;
  return empty;
}

}  // namespace penumbra
