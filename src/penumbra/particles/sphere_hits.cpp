#include "penumbra/particles/sphere_hits.h"

#include <atomic>
#include <bit>
#include <cmath>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"

namespace penumbra {
namespace {

constexpr std::uint64_t kEmptyKey = ~std::uint64_t{0};

// Distances are positive, so their float bits order like the floats; the id breaks ties.
std::uint64_t depth_key(float t, std::uint32_t id) {
  return (static_cast<std::uint64_t>(std::bit_cast<std::uint32_t>(t)) << 32) | id;
}

void atomic_min(std::atomic<std::uint64_t>& slot, std::uint64_t key) {
  std::uint64_t cur = slot.load(std::memory_order_relaxed);
  while (key < cur && !slot.compare_exchange_weak(cur, key, std::memory_order_relaxed)) {
  }
}

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
  lo = (a * z - root) / denom;
  hi = (a * z + root) / denom;
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
  const std::size_t pixels = static_cast<std::size_t>(camera.width) * static_cast<std::size_t>(camera.height);
  std::vector<std::atomic<std::uint64_t>> keys(pixels);
  parallel_for(pixels, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) keys[i].store(kEmptyKey, std::memory_order_relaxed);
  }, 1 << 16);

  parallel_for(particles.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const Sphere& s = particles.spheres[i];
      const Vec3 l = m.frame.to_local(s.center - m.eye);
      const float z = -l.z;  // distance in front of the eye
      if (z <= s.radius) continue;  // behind the eye or containing it
      float sx_lo, sx_hi, sy_lo, sy_hi;
      projected_range(l.x, z, s.radius, sx_lo, sx_hi);
      projected_range(l.y, z, s.radius, sy_lo, sy_hi);
      const int x0 = std::max(0, static_cast<int>(std::floor(m.pixel_x(sx_lo) - 0.5f)));
      const int x1 = std::min(m.width - 1, static_cast<int>(std::ceil(m.pixel_x(sx_hi) - 0.5f)));
      const int y0 = std::max(0, static_cast<int>(std::floor(m.pixel_y(sy_hi) - 0.5f)));
      const int y1 = std::min(m.height - 1, static_cast<int>(std::ceil(m.pixel_y(sy_lo) - 0.5f)));
      const auto id = static_cast<std::uint32_t>(i);
      for (int y = y0; y <= y1; ++y) {
        for (int x = x0; x <= x1; ++x) {
          const float t = intersect_sphere(Ray{m.eye, m.direction(x, y)}, s, 0, kInfinity);
          if (t == kInfinity) continue;
          atomic_min(keys[static_cast<std::size_t>(y) * static_cast<std::size_t>(m.width) + static_cast<std::size_t>(x)],
                     depth_key(t, id));
        }
      }
    }
  }, 1024);

  SphereHits hits;
  hits.width = camera.width;
  hits.height = camera.height;
  hits.t.assign(pixels, kInfinity);
  hits.id.assign(pixels, kNoSphere);
  parallel_for(pixels, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      const std::uint64_t k = keys[i].load(std::memory_order_relaxed);
      if (k == kEmptyKey) continue;
      hits.t[i] = std::bit_cast<float>(static_cast<std::uint32_t>(k >> 32));
      hits.id[i] = static_cast<std::uint32_t>(k & 0xFFFFFFFFu);
    }
  }, 1 << 16);
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
