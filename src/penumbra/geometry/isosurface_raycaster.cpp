#include "penumbra/geometry/isosurface_raycaster.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "penumbra/core/parallel.h"
#include "penumbra/geometry/trilinear_root.h"

namespace penumbra {

namespace {

using Index3 = std::array<int, 3>;

// The ray in continuous cell coordinates (cell (i, j, k) spans [i, i + 1] x ...), for the DDAs.
struct RayInCells {
  std::array<float, 3> origin, direction, inv_direction;
  RayInCells(const Volume& volume, const Ray& ray) {
    const Vec3 o = volume.to_voxel(ray.origin);
    for (int a = 0; a < 3; ++a) {
      const auto i = static_cast<std::size_t>(a);
      origin[i] = o[a];
      direction[i] = ray.direction[a] / volume.spacing()[a];
      inv_direction[i] = 1.0f / direction[i];
      if (std::isinf(inv_direction[i])) direction[i] = 0;  // too small to ever cross a cell: no steps
    }
  }
};

// 3D-DDA (Amanatides & Woo 1987) over the nodes of `size` cells a side with indices in [lo, hi), for
// the ray's parameters [t0, t1]: calls visit(node, ta, tb) in ray order until it returns true. The
// start node is the one holding the point at t0, clamped into the range; each crossing parameter is
// computed from its plane (not accumulated), so long walks do not drift.
template <class Visit>
bool walk(const RayInCells& r, int size, const Index3& lo, const Index3& hi, float t0, float t1, Visit&& visit) {
  Index3 node, step;
  std::array<float, 3> t_next;
  const auto crossing = [&](std::size_t a) {
    if (step[a] == 0) return kInfinity;
    const int plane = (node[a] + (step[a] > 0 ? 1 : 0)) * size;
    return (static_cast<float>(plane) - r.origin[a]) * r.inv_direction[a];
  };
  for (std::size_t a = 0; a < 3; ++a) {
    const float p = r.origin[a] + r.direction[a] * t0;
    node[a] = std::clamp(static_cast<int>(std::floor(p / static_cast<float>(size))), lo[a], hi[a] - 1);
    step[a] = r.direction[a] > 0 ? 1 : (r.direction[a] < 0 ? -1 : 0);
    t_next[a] = crossing(a);
  }
  float ta = t0;
  for (;;) {
    const std::size_t axis = t_next[0] < t_next[1] ? (t_next[0] < t_next[2] ? 0 : 2) : (t_next[1] < t_next[2] ? 1 : 2);
    const float tb = std::clamp(t_next[axis], ta, t1);
    if (visit(node, ta, tb)) return true;
    if (tb >= t1) return false;
    node[axis] += step[axis];
    if (node[axis] < lo[axis] || node[axis] >= hi[axis]) return false;
    t_next[axis] = crossing(axis);
    ta = tb;
  }
}

// One ray's walk down the GridTree, for voxels of type T.
template <class T>
class Traversal {
public:
  Traversal(const GridTree& tree, float isovalue, const Ray& ray)
      : tree_(tree), volume_(tree.volume()), data_(volume_.data_as<T>()), isovalue_(isovalue), cells_(volume_, ray),
        grid_ray_(volume_, ray) {
    const auto s = volume_.strides();
    for (std::size_t n = 0; n < 8; ++n) corner_offset_[n] = (n & 1) * s[0] + ((n >> 1) & 1) * s[1] + (n >> 2) * s[2];
  }

  float first_hit(float t0, float t1) {
    visit_node(tree_.levels() - 1, {0, 0, 0}, t0, t1);
    return hit_;
  }

private:
  // A node whose range does not straddle the isovalue is all inside or all outside.
  bool visit_node(int level, const Index3& node, float t0, float t1) {
    if (!tree_.may_contain(level, node[0], node[1], node[2], isovalue_))
      return enter_uniform(tree_.range(level, node[0], node[1], node[2])[0] >= isovalue_, t0);
    if (level == 0) {
      Index3 lo, hi;
      tree_.node_cells(0, node[0], node[1], node[2], lo, hi);
      return walk(cells_, 1, lo, hi, t0, t1, [&](const Index3& c, float ta, float tb) { return visit_cell(c, ta, tb); });
    }
    const Index3& below = tree_.level_dims(level - 1);
    Index3 lo, hi;
    for (std::size_t a = 0; a < 3; ++a) {
      lo[a] = 2 * node[a];
      hi[a] = std::min(lo[a] + 2, below[a]);
    }
    return walk(cells_, tree_.node_cells(level - 1), lo, hi, t0, t1,
                [&](const Index3& child, float ta, float tb) { return visit_node(level - 1, child, ta, tb); });
  }

  bool visit_cell(const Index3& c, float t0, float t1) {
    const T* base = data_ + volume_.index(c[0], c[1], c[2]);
    CornerValues v;
    float lo = kInfinity, hi = -kInfinity;
    for (std::size_t n = 0; n < 8; ++n) {
      v[n] = static_cast<float>(base[corner_offset_[n]]);
      lo = std::min(lo, v[n]);
      hi = std::max(hi, v[n]);
    }
    if (!range_straddles(lo, hi, isovalue_)) return enter_uniform(lo >= isovalue_, t0);
    if (state_ == State::Unknown) state_ = inside_at(v, c, isovalue_, grid_ray_, t0) ? State::Inside : State::Outside;
    const float t = first_state_change(v, c, isovalue_, grid_ray_, t0, t1, state_ == State::Inside);
    if (t == kInfinity) return false;
    hit_ = t;
    return true;
  }

  // Entering a region of known state at t: a crossing when the state differs from the one carried.
  bool enter_uniform(bool inside, float t) {
    const State s = inside ? State::Inside : State::Outside;
    if (state_ != State::Unknown && state_ != s) {
      hit_ = t;
      return true;
    }
    state_ = s;
    return false;
  }

  enum class State { Unknown, Outside, Inside };

  const GridTree& tree_;
  const Volume& volume_;
  const T* data_;
  float isovalue_;
  RayInCells cells_;
  GridRay grid_ray_;
  std::array<std::size_t, 8> corner_offset_;
  State state_ = State::Unknown;
  float hit_ = kInfinity;
};

template <class T>
float first_hit_typed(const GridTree& tree, float isovalue, const Ray& ray, float t0, float t1) {
  return Traversal<T>(tree, isovalue, ray).first_hit(t0, t1);
}

}  // namespace

float IsosurfaceRaycaster::first_hit(const Ray& ray, float tmin, float tmax) const {
  float t0, t1;
  if (!tree_->cell_box({0, 0, 0}, tree_->cells()).clip(ray, t0, t1, tmin, tmax)) return kInfinity;
  switch (tree_->volume().type()) {
    case ScalarType::UInt8: return first_hit_typed<std::uint8_t>(*tree_, isovalue_, ray, t0, t1);
    case ScalarType::Int16: return first_hit_typed<std::int16_t>(*tree_, isovalue_, ray, t0, t1);
    case ScalarType::UInt16: return first_hit_typed<std::uint16_t>(*tree_, isovalue_, ray, t0, t1);
    case ScalarType::Float32: return first_hit_typed<float>(*tree_, isovalue_, ray, t0, t1);
  }
  return kInfinity;
}

float IsosurfaceRaycaster::first_hit(const Ray& ray, float tmin, float tmax, const IsosurfaceRaycaster& finer,
                                     const IsosurfaceRaycaster** met) const {
  if (met) *met = this;
  float f0, f1;
  if (!finer.tree_->volume().bounds().clip(ray, f0, f1, tmin, tmax)) return first_hit(ray, tmin, tmax);
  float t = first_hit(ray, tmin, f0);
  if (t != kInfinity) return t;
  t = finer.first_hit(ray, f0, f1);
  if (t != kInfinity) {
    if (met) *met = &finer;
    return t;
  }
  return first_hit(ray, f1, tmax);
}

IsoPoints IsosurfaceRaycaster::render(const Camera& camera, const ClipPlanes& clip, const IsosurfaceRaycaster* finer) const {
  const PrimaryRays rays(camera);
  const std::size_t pixels = static_cast<std::size_t>(camera.width) * static_cast<std::size_t>(camera.height);
  std::vector<IsoPoint> at_pixel(pixels);
  std::vector<std::uint8_t> hit(pixels, 0);
  parallel_for_tiles(camera.width, camera.height, 16, [&](const Tile& tile) {
    for (int y = tile.y0; y < tile.y1; ++y)
      for (int x = tile.x0; x < tile.x1; ++x) {
        const Ray ray = rays.ray(x, y);
        float t0 = 0, t1 = kInfinity;  // the part the clip planes keep
        if (!clip.keep(ray, t0, t1)) continue;
        const IsosurfaceRaycaster* met = this;
        const float t = finer ? first_hit(ray, t0, t1, *finer, &met) : first_hit(ray, t0, t1);
        if (t == kInfinity) continue;
        const Vec3 p = ray.at(t);
        Vec3 n = normalize(met->tree_->volume().gradient(p));
        if (n == Vec3{0, 0, 0}) n = -ray.direction;
        if (dot(n, ray.direction) > 0) n = -n;
        const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(camera.width) + static_cast<std::size_t>(x);
        at_pixel[i] = IsoPoint{p, n, t, static_cast<std::uint32_t>(i)};
        hit[i] = 1;
      }
  });
  return points_in_pixel_order(at_pixel, hit);
}

}  // namespace penumbra
