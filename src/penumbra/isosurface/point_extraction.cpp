#include "penumbra/isosurface/point_extraction.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <vector>

#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/geometry/trilinear_root.h"

namespace penumbra {

namespace {

using Cells = std::array<int, 3>;

// An inclusive rectangle of pixels inside the image (a tile, or a box's footprint clipped to one).
struct TileRect {
  int x0, y0, x1, y1;  // inclusive
  bool empty() const { return x0 > x1 || y0 > y1; }
  bool single() const { return x0 == x1 && y0 == y1; }
};

// One tile's traversal (see point_extraction.h). T is the volume's voxel type.
template <class T>
class TileExtractor {
public:
  TileExtractor(const GridTree& tree, float isovalue, const ViewProjection& view, const ExtractionOptions& options,
                const Tile& tile)
      : tree_(tree), volume_(tree.volume()), data_(tree.volume().data_as<T>()), iso_(isovalue), view_(view),
        options_(options), tile_{tile.x0, tile.y0, tile.x1 - 1, tile.y1 - 1},
        vis_(tile.x1 - tile.x0, tile.y1 - tile.y0, options.start == nullptr) {
    cell_diagonal_ = length(volume_.spacing());
    stride_ = volume_.strides();
    if (options.start)
      for (int y = tile.y0; y < tile.y1; ++y)
        for (int x = tile.x0; x < tile.x1; ++x)
          if (options.start->visible(x, y)) vis_.set_visible(x - tile.x0, y - tile.y0);
  }

  void run() {
    const int top = tree_.levels() - 1;
    visit_node(top, 0, 0, 0);
  }

  IsoPoints points;
  ExtractionStats stats;

private:
  Vec3 world(const Cells& c) const {
    const Vec3& s = volume_.spacing();
    const Vec3& o = volume_.origin();
    return {o.x + static_cast<float>(c[0]) * s.x, o.y + static_cast<float>(c[1]) * s.y, o.z + static_cast<float>(c[2]) * s.z};
  }

  // The pixels a world box may cover, clipped to the tile (all of it when the box reaches behind a
  // perspective eye); `extent` is the larger side of its projection in pixels.
  TileRect project(const Box3& b, float& extent) const {
    float xmin = kInfinity, ymin = kInfinity, xmax = -kInfinity, ymax = -kInfinity;
    for (int c = 0; c < 8; ++c) {
      const Vec3 p{(c & 1) ? b.hi.x : b.lo.x, (c & 2) ? b.hi.y : b.lo.y, (c & 4) ? b.hi.z : b.lo.z};
      float px, py;
      if (!view_.project(p, px, py)) {
        extent = kInfinity;
        return tile_;
      }
      xmin = std::min(xmin, px);
      xmax = std::max(xmax, px);
      ymin = std::min(ymin, py);
      ymax = std::max(ymax, py);
    }
    extent = std::max(xmax - xmin, ymax - ymin);
    // pixel x covers [x, x + 1); stay inside int range for boxes far outside the view
    const auto pix = [](float v) { return static_cast<int>(std::floor(std::clamp(v, -1e6f, 1e6f))); };
    return TileRect{std::max(pix(xmin), tile_.x0), std::max(pix(ymin), tile_.y0), std::min(pix(xmax), tile_.x1),
                     std::min(pix(ymax), tile_.y1)};
  }

  bool any_visible(const TileRect& r) const {
    if (r.empty()) return false;
    if (!options_.visibility_pruning) return true;
    return vis_.any_visible(r.x0 - tile_.x0, r.y0 - tile_.y0, r.x1 - tile_.x0, r.y1 - tile_.y0);
  }
  bool visible(int x, int y) const { return vis_.visible(x - tile_.x0, y - tile_.y0); }

  // Front-to-back order of the (up to) 8 children split at world point `split`: visiting child
  // first ^ o for o = 0 … 7 puts every child before those it could hide (the near side of each
  // splitting plane first).
  int first_child(const Vec3& split) const {
    if (view_.orthographic) {
      const Vec3 f = -view_.frame.w;
      return (f.x < 0 ? 1 : 0) | (f.y < 0 ? 2 : 0) | (f.z < 0 ? 4 : 0);
    }
    const Vec3& e = view_.eye;
    return (e.x >= split.x ? 1 : 0) | (e.y >= split.y ? 2 : 0) | (e.z >= split.z ? 4 : 0);
  }

  // Shared test of a node or block: value range, projection, visibility, far-subvolume collapse.
  // True when its children should be visited.
  bool enter(float lo_value, float hi_value, const Cells& lo, const Cells& hi, float& extent) {
    ++stats.nodes_visited;
    if (!range_straddles(lo_value, hi_value, iso_)) {
      ++stats.value_pruned;
      return false;
    }
    const Box3 box{world(lo), world(hi)};
    if (options_.exclude && options_.exclude->contains(box.lo) && options_.exclude->contains(box.hi)) return false;  // drawn by another pass
    const TileRect r = project(box, extent);
    if (!any_visible(r)) {
      ++stats.visibility_pruned;
      return false;
    }
    if (options_.collapse && r.single() && extent < 1.0f) {
      collapse(box, r.x0, r.y0);
      return false;
    }
    return true;
  }

  void visit_node(int level, int i, int j, int k) {
    Cells lo, hi;
    tree_.node_cells(level, i, j, k, lo, hi);
    const auto& range = tree_.range(level, i, j, k);
    float extent;
    if (!enter(range[0], range[1], lo, hi, extent)) return;
    if (level == 0) {
      visit_brick(lo, hi);
      return;
    }
    const int half = tree_.node_cells(level - 1);
    const auto& dims = tree_.level_dims(level - 1);
    const int first = first_child(world({lo[0] + half, lo[1] + half, lo[2] + half}));
    for (int o = 0; o < 8; ++o) {
      const int c = first ^ o;
      const int ci = 2 * i + (c & 1), cj = 2 * j + ((c >> 1) & 1), ck = 2 * k + (c >> 2);
      if (ci < dims[0] && cj < dims[1] && ck < dims[2]) visit_node(level - 1, ci, cj, ck);
    }
  }

  // The cells of a brick, as 2x2x2 blocks and then single cells, in front-to-back order.
  void visit_brick(const Cells& lo, const Cells& hi) { visit_split(lo, hi, 2, false); }

  // `sub_pixel`: the enclosing block projects to at most a pixel, so every cell in it does too.
  void visit_split(const Cells& lo, const Cells& hi, int size, bool sub_pixel) {
    const int first = first_child(world({lo[0] + size, lo[1] + size, lo[2] + size}));
    for (int o = 0; o < 8; ++o) {
      const int c = first ^ o;
      Cells clo, chi;
      bool exists = true;
      for (std::size_t a = 0; a < 3; ++a) {
        clo[a] = lo[a] + ((c >> a) & 1) * size;
        chi[a] = std::min(clo[a] + size, hi[a]);
        exists = exists && clo[a] < chi[a];
      }
      if (!exists) continue;
      if (size == 1) visit_cell(clo, sub_pixel);
      else visit_block(clo, chi);
    }
  }

  void visit_block(const Cells& lo, const Cells& hi) {
    T mn = data_[index(lo)], mx = mn;
    for (int z = lo[2]; z <= hi[2]; ++z)
      for (int y = lo[1]; y <= hi[1]; ++y) {
        if (volume_.is_bricked()) {  // no rows: one look-up a voxel
          for (int x = lo[0]; x <= hi[0]; ++x) {
            const T v = data_[volume_.index(x, y, z)];
            mn = std::min(mn, v);
            mx = std::max(mx, v);
          }
          continue;
        }
        const T* row = data_ + index({0, y, z});
        for (int x = lo[0]; x <= hi[0]; ++x) {
          mn = std::min(mn, row[x]);
          mx = std::max(mx, row[x]);
        }
      }
    float extent;
    if (!enter(static_cast<float>(mn), static_cast<float>(mx), lo, hi, extent)) return;
    visit_split(lo, hi, 1, extent <= 1.0f);
  }

  std::size_t index(const Cells& c) const { return volume_.index(c[0], c[1], c[2]); }

  void visit_cell(const Cells& c, bool sub_pixel) {
    const std::size_t base = index(c);
    std::array<float, 8> v;
    float mn = kInfinity, mx = -kInfinity;
    for (int n = 0; n < 8; ++n) {
      v[static_cast<std::size_t>(n)] = static_cast<float>(
          data_[base + ((n & 1) ? stride_[0] : 0) + ((n & 2) ? stride_[1] : 0) + ((n & 4) ? stride_[2] : 0)]);
      mn = std::min(mn, v[static_cast<std::size_t>(n)]);
      mx = std::max(mx, v[static_cast<std::size_t>(n)]);
    }
    if (!range_straddles(mn, mx, iso_)) return;
    const Cells hi{c[0] + 1, c[1] + 1, c[2] + 1};
    const Box3 box{world(c), world(hi)};
    float extent = 0;
    TileRect r{0, 0, -1, -1};
    if (!sub_pixel) {  // (a cell inside a sub-pixel block needs only its point's pixel, tested below)
      r = project(box, extent);
      if (!any_visible(r)) return;
    }
    ++stats.cells_visited;
    if (extent <= 1.0f) {
      // Sub-pixel cell: one point, the mean of the crossings on its 12 edges (§3.2).
      const Vec3 p = edge_crossing_mean(c, v);
      float px, py;
      if (!view_.project(p, px, py)) return;
      const int x = static_cast<int>(std::floor(px)), y = static_cast<int>(std::floor(py));
      if (x < tile_.x0 || x > tile_.x1 || y < tile_.y0 || y > tile_.y1 || !visible(x, y)) return;
      emit(p, x, y, nullptr, cell_diagonal_);
      return;
    }
    // A cell wider than a pixel: the exact surface point along each visible pixel's ray.
    for (int y = r.y0; y <= r.y1; ++y)
      for (int x = r.x0; x <= r.x1; ++x) {
        if (!visible(x, y)) continue;
        const Ray ray = view_.ray(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f);
        float t0, t1;
        if (!box.clip(ray, t0, t1) || (options_.clip && !options_.clip->keep(ray, t0, t1))) continue;
        float e0 = t1, e1 = t1;  // the part of [t0, t1] inside the excluded box: searched around
        if (options_.exclude && !options_.exclude->clip(ray, e0, e1, t0, t1)) e0 = e1 = t1;
        float t = first_crossing_in_cell(volume_, c, iso_, ray, t0, e0);
        if (t == kInfinity && e1 < t1) t = first_crossing_in_cell(volume_, c, iso_, ray, e1, t1);
        if (t < kInfinity) emit(ray.at(t), x, y);
      }
  }

  Vec3 edge_crossing_mean(const Cells& c, const std::array<float, 8>& v) const {
    Vec3 sum;
    int n = 0;
    for (int a = 0; a < 8; ++a)
      for (int axis = 0; axis < 3; ++axis) {
        const int b = a | (1 << axis);
        if (b == a) continue;
        const float va = v[static_cast<std::size_t>(a)], vb = v[static_cast<std::size_t>(b)];
        if ((va < iso_) == (vb < iso_)) continue;
        const float t = (iso_ - va) / (vb - va);
        Vec3 local{static_cast<float>(a & 1), static_cast<float>((a >> 1) & 1), static_cast<float>((a >> 2) & 1)};
        (axis == 0 ? local.x : axis == 1 ? local.y : local.z) += t;
        sum += local;
        ++n;
      }
    const Vec3& s = volume_.spacing();
    const Vec3 o = world(c);
    const Vec3 m = sum / static_cast<float>(n);
    return {o.x + m.x * s.x, o.y + m.y * s.y, o.z + m.z * s.z};
  }

  // The far-subvolume point: the node's centre moved onto the surface by one Newton step along the
  // gradient and kept inside the node.
  void collapse(const Box3& box, int x, int y) {
    const Vec3 c = box.center();
    const Vec3 g = volume_.gradient(c);
    const float g2 = dot(g, g);
    Vec3 p = c;
    if (g2 > 0) p = c - g * ((volume_.sample(c) - iso_) / g2);
    p = min(max(p, box.lo), box.hi);
    ++stats.collapsed;
    emit(p, x, y, &g, length(box.extent()));
  }

  void emit(const Vec3& p, int x, int y, const Vec3* gradient = nullptr, float error = 0) {
    if (options_.clip && options_.clip->removes(p)) return;  // cut away: the pixel stays open
    if (options_.exclude && options_.exclude->contains(p)) return;  // another pass draws it
    IsoPoint q;
    q.position = p;
    q.error = error;
    q.distance = view_.distance(p);
    q.pixel = static_cast<std::uint32_t>(y) * static_cast<std::uint32_t>(view_.width) + static_cast<std::uint32_t>(x);
    if (options_.normals) {
      const Vec3 g = gradient ? *gradient : volume_.gradient(p);
      const Vec3 to_view = view_.orthographic ? view_.frame.w : view_.eye - p;
      q.normal = dot(g, g) > 0 ? normalize(g) : normalize(to_view);
      if (dot(q.normal, to_view) < 0) q.normal = -q.normal;
    }
    points.push_back(q);
    vis_.set_covered(x - tile_.x0, y - tile_.y0);
  }

  const GridTree& tree_;
  const Volume& volume_;
  const T* data_;
  float iso_;
  const ViewProjection& view_;
  const ExtractionOptions& options_;
  TileRect tile_;
  VisibilityBuffer vis_;
  std::array<std::size_t, 3> stride_;
  float cell_diagonal_;
};

template <class T>
Extraction extract_typed(const GridTree& tree, float isovalue, const ViewProjection& view, const ExtractionOptions& options) {
  const int tile = std::max(8, options.tile);
  const int tx = (view.width + tile - 1) / tile, ty = (view.height + tile - 1) / tile;
  std::vector<IsoPoints> points(static_cast<std::size_t>(tx) * static_cast<std::size_t>(ty));
  std::vector<ExtractionStats> stats(points.size());
  parallel_for(points.size(), [&](std::size_t b, std::size_t e) {
    for (std::size_t t = b; t < e; ++t) {
      const int x0 = static_cast<int>(t % static_cast<std::size_t>(tx)) * tile;
      const int y0 = static_cast<int>(t / static_cast<std::size_t>(tx)) * tile;
      TileExtractor<T> ex(tree, isovalue, view, options,
                          Tile{x0, y0, std::min(x0 + tile, view.width), std::min(y0 + tile, view.height)});
      ex.run();
      points[t] = std::move(ex.points);
      stats[t] = ex.stats;
    }
  });
  Extraction out;
  std::size_t n = 0;
  for (const auto& p : points) n += p.size();
  out.points.reserve(n);
  for (std::size_t t = 0; t < points.size(); ++t) {
    out.points.insert(out.points.end(), points[t].begin(), points[t].end());
    out.stats.add(stats[t]);
  }
  return out;
}

}  // namespace

Extraction extract_points(const GridTree& tree, float isovalue, const ViewProjection& view, const ExtractionOptions& options) {
  Timer timer;
  Extraction e;
  switch (tree.volume().type()) {
    case ScalarType::UInt8: e = extract_typed<std::uint8_t>(tree, isovalue, view, options); break;
    case ScalarType::Int16: e = extract_typed<std::int16_t>(tree, isovalue, view, options); break;
    case ScalarType::UInt16: e = extract_typed<std::uint16_t>(tree, isovalue, view, options); break;
    case ScalarType::Float32: e = extract_typed<float>(tree, isovalue, view, options); break;
  }
  e.stats.ms = timer.elapsed_ms();
  return e;
}

}  // namespace penumbra
