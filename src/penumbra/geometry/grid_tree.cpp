#include "penumbra/geometry/grid_tree.h"

#include <algorithm>
#include <cstdint>
#include <limits>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"

namespace penumbra {

namespace {

// Level 0: the voxels [4b, 4b + 4] of every brick b (one voxel of overlap with the next brick, since a
// cell touches the voxels on both of its faces), scanned in the volume's own type.
template <class T>
void brick_ranges(const Volume& v, const std::array<int, 3>& bricks, std::vector<std::array<float, 2>>& out) {
  const T* data = v.data_as<T>();
  const auto& d = v.dims();
  const int b = GridTree::kBrickCells;
  parallel_for(static_cast<std::size_t>(bricks[2]) * bricks[1], [&](std::size_t r0, std::size_t r1) {
    std::vector<T> lo(static_cast<std::size_t>(bricks[0])), hi(static_cast<std::size_t>(bricks[0]));
    for (std::size_t r = r0; r < r1; ++r) {
      const int bk = static_cast<int>(r / static_cast<std::size_t>(bricks[1]));
      const int bj = static_cast<int>(r % static_cast<std::size_t>(bricks[1]));
      std::fill(lo.begin(), lo.end(), std::numeric_limits<T>::max());
      std::fill(hi.begin(), hi.end(), std::numeric_limits<T>::lowest());
      for (int z = bk * b; z <= std::min(bk * b + b, d[2] - 1); ++z)
        for (int y = bj * b; y <= std::min(bj * b + b, d[1] - 1); ++y) {
          const T* row = data + v.index(0, y, z);  // dense: the row; bricked: one look-up a voxel
          for (int bi = 0; bi < bricks[0]; ++bi) {
            T mn = lo[static_cast<std::size_t>(bi)], mx = hi[static_cast<std::size_t>(bi)];
            for (int x = bi * b; x <= std::min(bi * b + b, d[0] - 1); ++x) {
              const T value = v.is_bricked() ? data[v.index(x, y, z)] : row[x];
              mn = std::min(mn, value);
              mx = std::max(mx, value);
            }
            lo[static_cast<std::size_t>(bi)] = mn;
            hi[static_cast<std::size_t>(bi)] = mx;
          }
        }
      for (int bi = 0; bi < bricks[0]; ++bi)
        out[r * static_cast<std::size_t>(bricks[0]) + static_cast<std::size_t>(bi)] = {
            static_cast<float>(lo[static_cast<std::size_t>(bi)]), static_cast<float>(hi[static_cast<std::size_t>(bi)])};
    }
  });
}

}  // namespace

GridTree::GridTree(const Volume& volume) : volume_(&volume) {
  Timer timer;
  const auto& d = volume.dims();
  for (int a = 0; a < 3; ++a) {
    if (d[static_cast<std::size_t>(a)] < 2)
      throw Error("isosurface: the volume needs at least 2 voxels along each axis (has " + std::to_string(d[0]) +
                  " x " + std::to_string(d[1]) + " x " + std::to_string(d[2]) + ")");
    cells_[static_cast<std::size_t>(a)] = d[static_cast<std::size_t>(a)] - 1;
  }
  Level bricks;
  for (int a = 0; a < 3; ++a) bricks.dims[static_cast<std::size_t>(a)] = (cells_[static_cast<std::size_t>(a)] + kBrickCells - 1) / kBrickCells;
  bricks.range.resize(static_cast<std::size_t>(bricks.dims[0]) * bricks.dims[1] * bricks.dims[2]);
  switch (volume.type()) {
    case ScalarType::UInt8: brick_ranges<std::uint8_t>(volume, bricks.dims, bricks.range); break;
    case ScalarType::Int16: brick_ranges<std::int16_t>(volume, bricks.dims, bricks.range); break;
    case ScalarType::UInt16: brick_ranges<std::uint16_t>(volume, bricks.dims, bricks.range); break;
    case ScalarType::Float32: brick_ranges<float>(volume, bricks.dims, bricks.range); break;
  }
  levels_.push_back(std::move(bricks));
  // Each level above: the union of the 2x2x2 children's ranges.
  while (levels_.back().dims != std::array<int, 3>{1, 1, 1}) {
    const Level& c = levels_.back();
    Level p;
    for (int a = 0; a < 3; ++a) p.dims[static_cast<std::size_t>(a)] = (c.dims[static_cast<std::size_t>(a)] + 1) / 2;
    p.range.assign(static_cast<std::size_t>(p.dims[0]) * p.dims[1] * p.dims[2],
                   {std::numeric_limits<float>::max(), std::numeric_limits<float>::lowest()});
    for (int k = 0; k < c.dims[2]; ++k)
      for (int j = 0; j < c.dims[1]; ++j)
        for (int i = 0; i < c.dims[0]; ++i) {
          const auto& r = c.range[(static_cast<std::size_t>(k) * c.dims[1] + j) * c.dims[0] + i];
          auto& q = p.range[(static_cast<std::size_t>(k / 2) * p.dims[1] + j / 2) * p.dims[0] + i / 2];
          q[0] = std::min(q[0], r[0]);
          q[1] = std::max(q[1], r[1]);
        }
    levels_.push_back(std::move(p));
  }
  build_ms_ = timer.elapsed_ms();
}

void GridTree::node_cells(int level, int i, int j, int k, std::array<int, 3>& lo, std::array<int, 3>& hi) const {
  const int n = node_cells(level);
  const int idx[3] = {i, j, k};
  for (std::size_t a = 0; a < 3; ++a) {
    lo[a] = idx[a] * n;
    hi[a] = std::min(lo[a] + n, cells_[a]);
  }
}

Box3 GridTree::cell_box(const std::array<int, 3>& lo, const std::array<int, 3>& hi) const {
  const Vec3& s = volume_->spacing();
  const Vec3& o = volume_->origin();
  return Box3{{o.x + static_cast<float>(lo[0]) * s.x, o.y + static_cast<float>(lo[1]) * s.y, o.z + static_cast<float>(lo[2]) * s.z},
              {o.x + static_cast<float>(hi[0]) * s.x, o.y + static_cast<float>(hi[1]) * s.y, o.z + static_cast<float>(hi[2]) * s.z}};
}

std::size_t GridTree::memory_bytes() const {
  std::size_t bytes = 0;
  for (const Level& l : levels_) bytes += l.range.size() * sizeof(l.range[0]);
  return bytes;
}

}  // namespace penumbra
