#include "penumbra/particles/sphere_hits.h"

#include <array>
#include <atomic>
#include <cmath>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"

namespace penumbra {
namespace {

constexpr int kTile = 32;  // screen tiles of the splatting pass, in pixels

// The camera's primary-ray geometry, precomputed for the splatting loop.
struct ScreenMapping {
  Frame frame;
  Vec3 eye;
  float sx_scale, sy_scale;  // image-plane units per pixel
  int width, height;

  explicit ScreenMapping(const Camera& c)
      : frame(Frame::from_w(c.eye - c.target, c.up)), eye(c.eye), width(c.width), height(c.height) {
    const float tan_half = std::tan(radians(c.fov_deg) * 0.5f);
    const float aspect = static_cast<float>(c.width) / static_cast<float>(c.height);
    sx_scale = 2.0f * tan_half * aspect / static_cast<float>(c.width);
    sy_scale = 2.0f * tan_half / static_cast<float>(c.height);
  }
  float pixel_x(float sx) const { return sx / sx_scale + 0.5f * static_cast<float>(width); }
  float pixel_y(float sy) const { return 0.5f * static_cast<float>(height) - sy / sy_scale; }
  Vec3 direction(int x, int y) const {
    const float sx = (static_cast<float>(x) + 0.5f - 0.5f * static_cast<float>(width)) * sx_scale;
    const float sy = (0.5f * static_cast<float>(height) - static_cast<float>(y) - 0.5f) * sy_scale;
    return normalize(frame.u * sx + frame.v * sy - frame.w);
  }
};

// Range of a/z over a sphere of radius r centred at (a, z) in one view-space axis (z > r): the two
// tangent lines through the eye (closed form of the projected sphere's extent).
void projected_range(float a, float z, float r, float& lo, float& hi) {
  const float denom = z * z - r * r;
  const float root = r * std::sqrt(std::max(a * a + denom, 0.0f));
  const float inv = 1.0f / denom;
  lo = (a * z - root) * inv;
  hi = (a * z + root) * inv;
}

int floor_int(float v) {
  const int i = static_cast<int>(v);
  return i - (static_cast<float>(i) > v ? 1 : 0);
}

// Inclusive pixel rectangle; x1 < x0 when empty.
struct PixelRect {
  int x0 = 0, y0 = 0, x1 = -1, y1 = -1;
  bool empty() const { return x1 < x0 || y1 < y0; }
};

PixelRect pixel_rect(const ScreenMapping& m, const Sphere& s) {
  const Vec3 l = m.frame.to_local(s.center - m.eye);
  const float z = -l.z;  // distance in front of the eye
  if (z <= s.radius) return {};  // behind the eye or containing it
  float sx_lo, sx_hi, sy_lo, sy_hi;
  projected_range(l.x, z, s.radius, sx_lo, sx_hi);
  projected_range(l.y, z, s.radius, sy_lo, sy_hi);
  // pixel centres at i + 0.5; the values are clamped to just outside the image before the integer
  // floor (std::floor is a libm call on baseline x86-64, and a far-off value would overflow int)
  const float w = static_cast<float>(m.width), h = static_cast<float>(m.height);
  PixelRect r;
  r.x0 = std::max(0, floor_int(clamp(m.pixel_x(sx_lo) - 0.5f, -2.0f, w + 1)));
  r.x1 = std::min(m.width - 1, floor_int(clamp(m.pixel_x(sx_hi) - 0.5f, -2.0f, w + 1)) + 1);
  r.y0 = std::max(0, floor_int(clamp(m.pixel_y(sy_hi) - 0.5f, -2.0f, h + 1)));
  r.y1 = std::min(m.height - 1, floor_int(clamp(m.pixel_y(sy_lo) - 0.5f, -2.0f, h + 1)) + 1);
  return r;
}

}  // namespace

std::size_t SphereHits::covered() const {
  std::size_t n = 0;
  for (auto i : id) n += i != kNoSphere;
  return n;
}

std::string to_string(SphereRasterizer r) { return r == SphereRasterizer::Splat ? "splat" : "embree"; }

SphereRasterizer sphere_rasterizer_from_string(const std::string& s) {
  if (s == "splat") return SphereRasterizer::Splat;
  if (s == "embree") return SphereRasterizer::Embree;
  throw Error("unknown sphere renderer '" + s + "' (expected splat or embree)");
}

SphereHits splat_spheres(const ParticleSet& particles, const Camera& camera) {
  const ScreenMapping m(camera);
  const int tiles_x = (m.width + kTile - 1) / kTile, tiles_y = (m.height + kTile - 1) / kTile;
  const auto tile_count = static_cast<std::size_t>(tiles_x) * static_cast<std::size_t>(tiles_y);

  // 1. every sphere's pixel rectangle (empty when it is behind the eye or off screen)
  std::vector<PixelRect> rects(particles.size());
  parallel_for(particles.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) rects[i] = pixel_rect(m, particles.spheres[i]);
  }, 4096);

  // 2. bin the spheres into screen tiles: count, prefix sum, fill (a sphere goes to every tile its
  //    rectangle touches); the order inside a bin does not matter, the depth test breaks ties by id
  std::vector<std::atomic<std::uint32_t>> counts(tile_count);
  for (auto& c : counts) c.store(0, std::memory_order_relaxed);
  auto for_each_tile = [&](const PixelRect& r, auto&& body) {
    for (int ty = r.y0 / kTile; ty <= r.y1 / kTile; ++ty)
      for (int tx = r.x0 / kTile; tx <= r.x1 / kTile; ++tx)
        body(static_cast<std::size_t>(ty) * static_cast<std::size_t>(tiles_x) + static_cast<std::size_t>(tx));
  };
  parallel_for(particles.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i)
      if (!rects[i].empty()) for_each_tile(rects[i], [&](std::size_t t) { counts[t].fetch_add(1, std::memory_order_relaxed); });
  }, 4096);
  std::vector<std::size_t> offset(tile_count + 1, 0);
  for (std::size_t t = 0; t < tile_count; ++t) offset[t + 1] = offset[t] + counts[t].load(std::memory_order_relaxed);
  std::vector<std::uint32_t> binned(offset[tile_count]);
  for (std::size_t t = 0; t < tile_count; ++t) counts[t].store(0, std::memory_order_relaxed);
  parallel_for(particles.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i)
      if (!rects[i].empty())
        for_each_tile(rects[i], [&](std::size_t t) {
          binned[offset[t] + counts[t].fetch_add(1, std::memory_order_relaxed)] = static_cast<std::uint32_t>(i);
        });
  }, 4096);

  // 3. each tile: its spheres' exact ray tests into a depth buffer that stays in cache
  SphereHits hits;
  hits.width = camera.width;
  hits.height = camera.height;
  const std::size_t pixels = static_cast<std::size_t>(camera.width) * static_cast<std::size_t>(camera.height);
  hits.t.assign(pixels, kInfinity);
  hits.id.assign(pixels, kNoSphere);
  parallel_for(tile_count, [&](std::size_t t0, std::size_t t1) {
    std::array<float, kTile * kTile> depth;
    std::array<std::uint32_t, kTile * kTile> ids;
    std::array<Vec3, kTile * kTile> dirs;
    for (std::size_t t = t0; t < t1; ++t) {
      if (offset[t] == offset[t + 1]) continue;
      const int tx0 = static_cast<int>(t % static_cast<std::size_t>(tiles_x)) * kTile;
      const int ty0 = static_cast<int>(t / static_cast<std::size_t>(tiles_x)) * kTile;
      const int tx1 = std::min(tx0 + kTile, m.width) - 1, ty1 = std::min(ty0 + kTile, m.height) - 1;
      for (int y = ty0; y <= ty1; ++y)
        for (int x = tx0; x <= tx1; ++x) {
          const int k = (y - ty0) * kTile + (x - tx0);
          depth[static_cast<std::size_t>(k)] = kInfinity;
          ids[static_cast<std::size_t>(k)] = kNoSphere;
          dirs[static_cast<std::size_t>(k)] = m.direction(x, y);
        }
      for (std::size_t b = offset[t]; b < offset[t + 1]; ++b) {
        const std::uint32_t id = binned[b];
        const Sphere& s = particles.spheres[id];
        const PixelRect& r = rects[id];
        for (int y = std::max(r.y0, ty0); y <= std::min(r.y1, ty1); ++y)
          for (int x = std::max(r.x0, tx0); x <= std::min(r.x1, tx1); ++x) {
            const auto k = static_cast<std::size_t>((y - ty0) * kTile + (x - tx0));
            const float d = intersect_sphere(Ray{m.eye, dirs[k]}, s, 0, depth[k]);
            if (d < depth[k] || (d == depth[k] && d != kInfinity && id < ids[k])) {
              depth[k] = d;
              ids[k] = id;
            }
          }
      }
      for (int y = ty0; y <= ty1; ++y)
        for (int x = tx0; x <= tx1; ++x) {
          const auto k = static_cast<std::size_t>((y - ty0) * kTile + (x - tx0));
          const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(m.width) + static_cast<std::size_t>(x);
          hits.t[i] = depth[k];
          hits.id[i] = ids[k];
        }
    }
  });
  return hits;
}

SphereHits trace_spheres(const SphereBvh& bvh, const Camera& camera) {
  SphereHits hits;
  hits.width = camera.width;
  hits.height = camera.height;
  const std::size_t pixels = static_cast<std::size_t>(camera.width) * static_cast<std::size_t>(camera.height);
  hits.t.assign(pixels, kInfinity);
  hits.id.assign(pixels, kNoSphere);
  const ScreenMapping m(camera);
  parallel_for_tiles(camera.width, camera.height, 16, [&](const Tile& tile) {
    for (int y = tile.y0; y < tile.y1; ++y)
      for (int x = tile.x0; x < tile.x1; ++x) {
        const SphereHit h = bvh.first_hit(Ray{m.eye, m.direction(x, y)}, 0, kInfinity);
        const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(camera.width) + static_cast<std::size_t>(x);
        hits.t[i] = h.t;
        hits.id[i] = h.id;
      }
  });
  return hits;
}

}  // namespace penumbra
