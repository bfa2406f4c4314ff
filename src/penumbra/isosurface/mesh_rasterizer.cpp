// rasterize_mesh (marching_cubes.h): a software z-buffer for the marching-cubes baseline. Triangles
// are binned to 32x32-pixel tiles, then each tile fills its own z-buffer in mesh order: vertices
// projected as PrimaryRays projects (pixel centres at +0.5), clipped in camera space to the near plane
// and a guard band (Sutherland & Hodgman 1974), snapped to 1/256 pixel and filled with integer edge
// functions and the top-left rule (Pineda 1988), depths and attributes interpolated
// perspective-correctly (1/z is affine in screen space).
#include "penumbra/isosurface/marching_cubes.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>

#include "penumbra/core/parallel.h"

namespace penumbra {

namespace {

constexpr int kTileSize = 32;
constexpr std::int64_t kSubpixel = 256;  // fixed-point steps per pixel
// Triangles are clipped to this many pixels around the image: fixed-point coordinates then stay
// below 2^29, and the edge functions' products below 2^60.
constexpr float kGuardPixels = 1 << 20;
constexpr float kNearFraction = 1e-5f;      // near plane, as a fraction of the mesh's bounding box diagonal
constexpr std::size_t kBinChunk = 1 << 16;  // triangles binned per task
constexpr int kMaxPieces = 6;               // a triangle clipped by five planes: 8 vertices, 6 triangles

std::int64_t floor_div(std::int64_t a, std::int64_t b) { return a / b - ((a % b != 0) && (a < 0)); }
std::int64_t ceil_div(std::int64_t a, std::int64_t b) { return -floor_div(-a, b); }

// A pixel coordinate in fixed point, rounded half away from zero (a conversion the compiler inlines,
// unlike llround; the guard band keeps it far from overflow).
std::int64_t to_fixed(double pixel) {
  const double f = pixel * static_cast<double>(kSubpixel);
  return static_cast<std::int64_t>(f + (f >= 0 ? 0.5 : -0.5));
}

// A point in camera space (x right, y up, z forward from the eye) with its weights on the corners of
// the mesh triangle it lies on.
struct CameraVertex {
  Vec3 p;
  Vec3 weights;
};

struct ScreenVertex {
  std::int64_t x, y;  // pixel coordinates in 1/kSubpixel
  double inv_z;       // 1 / z: affine in screen space
  Vec3 weights;
};
using ScreenTriangle = std::array<ScreenVertex, 3>;

struct PixelRange {
  int x0 = 0, y0 = 0, x1 = -1, y1 = -1;  // inclusive; empty when x1 < x0
  bool empty() const { return x1 < x0 || y1 < y0; }
};

// The pixels whose centres lie in the triangle's bounding box, within [0, width) x [0, height).
PixelRange pixel_range(const ScreenTriangle& t, int width, int height) {
  std::int64_t lx = t[0].x, hx = t[0].x, ly = t[0].y, hy = t[0].y;
  for (const ScreenVertex& v : t) {
    lx = std::min(lx, v.x), hx = std::max(hx, v.x);
    ly = std::min(ly, v.y), hy = std::max(hy, v.y);
  }
  const std::int64_t half = kSubpixel / 2;
  return {static_cast<int>(std::max<std::int64_t>(ceil_div(lx - half, kSubpixel), 0)),
          static_cast<int>(std::max<std::int64_t>(ceil_div(ly - half, kSubpixel), 0)),
          static_cast<int>(std::min<std::int64_t>(floor_div(hx - half, kSubpixel), width - 1)),
          static_cast<int>(std::min<std::int64_t>(floor_div(hy - half, kSubpixel), height - 1))};
}

// Mesh triangles to screen triangles: camera space, clipping (Sutherland-Hodgman against the near
// plane and the guard band), perspective projection onto PrimaryRays' pixel coordinates, snapping.
class Projector {
public:
  Projector(const Camera& camera, float near)
      : rays(camera), near_(near), pixel_x0_(rays.pixel_x(0)), pixel_y0_(rays.pixel_y(0)),
        pixels_per_x_(rays.pixel_x(1) - rays.pixel_x(0)), pixels_per_y_(rays.pixel_y(1) - rays.pixel_y(0)) {
    const float half_w = 0.5f * static_cast<float>(camera.width), half_h = 0.5f * static_cast<float>(camera.height);
    guard_x_ = static_cast<float>((half_w + kGuardPixels) / pixels_per_x_);
    guard_y_ = static_cast<float>((half_h + kGuardPixels) / -pixels_per_y_);
  }

  int project(const TriangleMesh& mesh, std::size_t t, std::array<ScreenTriangle, kMaxPieces>& out) const {
    std::array<CameraVertex, 8> poly;
    int n = 3;
    bool inside = true;
    for (std::size_t i = 0; i < 3; ++i) {
      const Vec3 q = mesh.vertices[3 * t + i] - rays.eye;
      poly[i] = {{dot(q, rays.frame.u), dot(q, rays.frame.v), -dot(q, rays.frame.w)},
                 {i == 0 ? 1.0f : 0.0f, i == 1 ? 1.0f : 0.0f, i == 2 ? 1.0f : 0.0f}};
      for (int plane = 0; plane < 5; ++plane) inside = inside && distance(plane, poly[i].p) >= 0;
    }
    if (!inside)
      for (int plane = 0; plane < 5 && n > 0; ++plane) n = clip(poly, n, plane);
    if (n < 3) return 0;
    std::array<ScreenVertex, 8> screen;
    for (std::size_t i = 0; i < static_cast<std::size_t>(n); ++i) {
      const Vec3& p = poly[i].p;
      const double inv_z = 1.0 / p.z;  // PrimaryRays::pixel_x and pixel_y, as one affine map
      const double px = pixel_x0_ + pixels_per_x_ * (p.x * inv_z), py = pixel_y0_ + pixels_per_y_ * (p.y * inv_z);
      screen[i] = {to_fixed(px), to_fixed(py), inv_z, poly[i].weights};
    }
    for (int i = 1; i + 1 < n; ++i)
      out[static_cast<std::size_t>(i - 1)] = {screen[0], screen[static_cast<std::size_t>(i)], screen[static_cast<std::size_t>(i + 1)]};
    return n - 2;
  }

  const PrimaryRays rays;

private:
  // Signed distance to plane 0 (near), 1-4 (guard band left, right, bottom, top); inside is >= 0.
  float distance(int plane, const Vec3& p) const {
    switch (plane) {
      case 0: return p.z - near_;
      case 1: return guard_x_ * p.z + p.x;
      case 2: return guard_x_ * p.z - p.x;
      case 3: return guard_y_ * p.z + p.y;
      default: return guard_y_ * p.z - p.y;
    }
  }

  int clip(std::array<CameraVertex, 8>& poly, int n, int plane) const {
    std::array<CameraVertex, 8> out;
    int m = 0;
    for (int i = 0; i < n; ++i) {
      const CameraVertex& a = poly[static_cast<std::size_t>(i)];
      const CameraVertex& b = poly[static_cast<std::size_t>((i + 1) % n)];
      const float da = distance(plane, a.p), db = distance(plane, b.p);
      if (da >= 0) out[static_cast<std::size_t>(m++)] = a;
      if ((da >= 0) != (db >= 0)) {
        const float s = da / (da - db);
        out[static_cast<std::size_t>(m++)] = {a.p + (b.p - a.p) * s, a.weights + (b.weights - a.weights) * s};
      }
    }
    poly = out;
    return m;
  }

  float near_;
  double pixel_x0_, pixel_y0_, pixels_per_x_, pixels_per_y_;  // pixel = p0 + pixels_per * (x / z)
  float guard_x_, guard_y_;                                  // guard band: |x| <= guard_x * z, |y| <= guard_y * z
};

// A tile's z-buffer: per pixel the largest 1/z so far, its triangle and its corner weights.
struct TileBuffer {
  explicit TileBuffer(const Tile& t)
      : tile(t), width(t.x1 - t.x0), inv_z(static_cast<std::size_t>(width * (t.y1 - t.y0)), 0.0),
        triangle(inv_z.size()), weights(inv_z.size()) {}
  Tile tile;
  int width;
  std::vector<double> inv_z;  // 0: empty
  std::vector<std::uint32_t> triangle;
  std::vector<Vec3> weights;
};

// Edge function of a -> b at p (twice the signed area of a, b, p; positive to the right of a -> b in
// pixel coordinates, where y grows downwards).
std::int64_t edge(const ScreenVertex& a, const ScreenVertex& b, std::int64_t px, std::int64_t py) {
  return (b.x - a.x) * (py - a.y) - (b.y - a.y) * (px - a.x);
}

// Top-left rule: a pixel centre exactly on an edge belongs to the triangle when that edge is a top
// edge (horizontal, interior below) or a left edge (interior to the right): of two triangles sharing
// the edge, exactly one. Returns the bias that makes "E + bias >= 0" the inside test.
std::int64_t fill_bias(const ScreenVertex& a, const ScreenVertex& b) {
  const std::int64_t dx = b.x - a.x, dy = b.y - a.y;
  return (dy < 0 || (dy == 0 && dx > 0)) ? 0 : -1;
}

// A fragment where the clip planes remove the mesh is not written, so the surface behind it shows.
void rasterize(ScreenTriangle t, std::uint32_t index, TileBuffer& buf, const TriangleMesh& mesh, const ClipPlanes& clip) {
  std::int64_t area = edge(t[0], t[1], t[2].x, t[2].y);
  if (area == 0) return;
  if (area < 0) {
    std::swap(t[1], t[2]);
    area = -area;
  }
  PixelRange r = pixel_range(t, buf.tile.x1, buf.tile.y1);
  r.x0 = std::max(r.x0, buf.tile.x0), r.y0 = std::max(r.y0, buf.tile.y0);
  if (r.empty()) return;
  // Edge i is opposite vertex i; its function over the area is vertex i's barycentric weight.
  const std::array<std::array<std::size_t, 2>, 3> ends = {{{1, 2}, {2, 0}, {0, 1}}};
  std::array<std::int64_t, 3> bias, step_x;
  for (std::size_t i = 0; i < 3; ++i) {
    const ScreenVertex &a = t[ends[i][0]], &b = t[ends[i][1]];
    bias[i] = fill_bias(a, b);
    step_x[i] = -(b.y - a.y) * kSubpixel;
  }
  const double inv_area = 1.0 / static_cast<double>(area);
  for (int y = r.y0; y <= r.y1; ++y) {
    const std::int64_t py = y * kSubpixel + kSubpixel / 2, px = r.x0 * kSubpixel + kSubpixel / 2;
    std::array<std::int64_t, 3> e;
    for (std::size_t i = 0; i < 3; ++i) e[i] = edge(t[ends[i][0]], t[ends[i][1]], px, py);
    for (int x = r.x0; x <= r.x1; ++x, e[0] += step_x[0], e[1] += step_x[1], e[2] += step_x[2]) {
      if (e[0] + bias[0] < 0 || e[1] + bias[1] < 0 || e[2] + bias[2] < 0) continue;
      std::array<double, 3> w;  // perspective-correct: the screen weights times 1/z, renormalized
      double inv_z = 0;
      for (std::size_t i = 0; i < 3; ++i) {
        w[i] = static_cast<double>(e[i]) * inv_area * t[i].inv_z;
        inv_z += w[i];
      }
      const std::size_t p = static_cast<std::size_t>((y - buf.tile.y0) * buf.width + (x - buf.tile.x0));
      if (inv_z <= buf.inv_z[p]) continue;
      Vec3 corner;
      for (std::size_t i = 0; i < 3; ++i) corner += t[i].weights * static_cast<float>(w[i] / inv_z);
      if (!clip.empty()) {
        const std::size_t v = 3 * static_cast<std::size_t>(index);
        if (clip.removes(mesh.vertices[v] * corner.x + mesh.vertices[v + 1] * corner.y + mesh.vertices[v + 2] * corner.z)) continue;
      }
      buf.inv_z[p] = inv_z;
      buf.triangle[p] = index;
      buf.weights[p] = corner;
    }
  }
}

// Each tile's mesh triangles, in mesh order: tiles[k] lists triangles[first[k] .. first[k + 1]).
struct Bins {
  std::vector<std::size_t> first;
  std::vector<std::uint32_t> triangles;
};

// Bins in chunks of kBinChunk triangles (a fixed split, so the order does not depend on the threads):
// each chunk lists its (tile, triangle) pairs and counts them per tile, then writes them at its
// offsets in each tile's list.
Bins bin_triangles(const TriangleMesh& mesh, const Projector& projector, int tiles_x, int tiles_y) {
  const std::size_t tiles = static_cast<std::size_t>(tiles_x) * static_cast<std::size_t>(tiles_y);
  const std::size_t chunks = (mesh.triangles() + kBinChunk - 1) / kBinChunk;
  std::vector<std::vector<std::array<std::uint32_t, 2>>> pairs(chunks);
  std::vector<std::vector<std::size_t>> count(chunks, std::vector<std::size_t>(tiles, 0));
  const int width = projector.rays.width, height = projector.rays.height;
  parallel_for(chunks, [&](std::size_t c0, std::size_t c1) {
    std::array<ScreenTriangle, kMaxPieces> pieces;
    for (std::size_t c = c0; c < c1; ++c)
      for (std::size_t t = c * kBinChunk; t < std::min(mesh.triangles(), (c + 1) * kBinChunk); ++t) {
        const int n = projector.project(mesh, t, pieces);
        PixelRange r{width, height, -1, -1};
        for (int i = 0; i < n; ++i) {
          const PixelRange p = pixel_range(pieces[static_cast<std::size_t>(i)], width, height);
          if (p.empty()) continue;
          r = {std::min(r.x0, p.x0), std::min(r.y0, p.y0), std::max(r.x1, p.x1), std::max(r.y1, p.y1)};
        }
        if (r.empty()) continue;  // covers no pixel centre: most triangles of a large mesh
        for (int ty = r.y0 / kTileSize; ty <= r.y1 / kTileSize; ++ty)
          for (int tx = r.x0 / kTileSize; tx <= r.x1 / kTileSize; ++tx) {
            const auto tile = static_cast<std::uint32_t>(ty * tiles_x + tx);
            pairs[c].push_back({tile, static_cast<std::uint32_t>(t)});
            ++count[c][tile];
          }
      }
  });
  Bins bins;
  bins.first.assign(tiles + 1, 0);
  for (std::size_t k = 0; k < tiles; ++k) {
    bins.first[k + 1] = bins.first[k];
    for (std::size_t c = 0; c < chunks; ++c) {
      const std::size_t n = count[c][k];
      count[c][k] = bins.first[k + 1];  // now: where chunk c writes its triangles of tile k
      bins.first[k + 1] += n;
    }
  }
  bins.triangles.resize(bins.first.back());
  parallel_for(chunks, [&](std::size_t c0, std::size_t c1) {
    for (std::size_t c = c0; c < c1; ++c)
      for (const auto& [tile, t] : pairs[c]) bins.triangles[count[c][tile]++] = t;
  });
  return bins;
}

float near_distance(const TriangleMesh& mesh) {
  Box3 box;
  for (const Vec3& p : mesh.vertices) box.extend(p);
  return std::max(kNearFraction * length(box.extent()), std::numeric_limits<float>::min());
}

}  // namespace

IsoPoints rasterize_mesh(const TriangleMesh& mesh, const Camera& camera, const ClipPlanes& clip) {
  if (mesh.triangles() == 0) return {};
  const Projector projector(camera, near_distance(mesh));
  const int w = camera.width, h = camera.height;
  const int tiles_x = (w + kTileSize - 1) / kTileSize, tiles_y = (h + kTileSize - 1) / kTileSize;
  const Bins bins = bin_triangles(mesh, projector, tiles_x, tiles_y);
  const std::size_t pixels = static_cast<std::size_t>(w) * static_cast<std::size_t>(h);
  std::vector<IsoPoint> at_pixel(pixels);
  std::vector<std::uint8_t> covered(pixels, 0);
  const Vec3 eye = camera.eye;
  parallel_for_tiles(w, h, kTileSize, [&](const Tile& tile) {
    TileBuffer buf(tile);
    const std::size_t k = static_cast<std::size_t>((tile.y0 / kTileSize) * tiles_x + tile.x0 / kTileSize);
    std::array<ScreenTriangle, kMaxPieces> pieces;
    for (std::size_t b = bins.first[k]; b < bins.first[k + 1]; ++b) {
      const std::uint32_t t = bins.triangles[b];
      const int n = projector.project(mesh, t, pieces);
      for (int i = 0; i < n; ++i) rasterize(pieces[static_cast<std::size_t>(i)], t, buf, mesh, clip);
    }
    for (int y = tile.y0; y < tile.y1; ++y)
      for (int x = tile.x0; x < tile.x1; ++x) {
        const std::size_t p = static_cast<std::size_t>((y - tile.y0) * buf.width + (x - tile.x0));
        if (buf.inv_z[p] == 0) continue;
        const std::size_t v = 3 * static_cast<std::size_t>(buf.triangle[p]);
        const Vec3& c = buf.weights[p];
        const Vec3 position = mesh.vertices[v] * c.x + mesh.vertices[v + 1] * c.y + mesh.vertices[v + 2] * c.z;
        const Vec3 view = position - eye;
        Vec3 normal = normalize(mesh.normals[v] * c.x + mesh.normals[v + 1] * c.y + mesh.normals[v + 2] * c.z);
        if (normal == Vec3{0, 0, 0}) normal = -normalize(view);
        if (dot(normal, view) > 0) normal = -normal;
        const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
        at_pixel[i] = IsoPoint{position, normal, length(view), static_cast<std::uint32_t>(i)};
        covered[i] = 1;
      }
  });
  return points_in_pixel_order(at_pixel, covered);
}

}  // namespace penumbra
