#include "penumbra/particles/sphere_hits.h"

#include <array>
#include <cmath>
#include <memory>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/geometry/cut_sphere.h"
#include "penumbra/particles/tile_bins.h"

namespace penumbra {
namespace {

// Range of a/z over a sphere of radius r centred at (a, z) in one view-space axis (z > r): the two
// tangent lines through the eye (closed form of the projected sphere's extent).
void projected_range(float a, float z, float r, float& lo, float& hi) {
  const float denom = z * z - r * r;
  const float root = r * std::sqrt(std::max(a * a + denom, 0.0f));
  const float inv = 1.0f / denom;
  lo = (a * z - root) * inv;
  hi = (a * z + root) * inv;
}

PixelRect pixel_rect(const PrimaryRays& m, const Sphere& s) {
  const Vec3 l = m.frame.to_local(s.center - m.eye);
  const float z = -l.z;  // distance in front of the eye
  if (z <= s.radius) return {};  // behind the eye or containing it
  float sx_lo, sx_hi, sy_lo, sy_hi;
  projected_range(l.x, z, s.radius, sx_lo, sx_hi);
  projected_range(l.y, z, s.radius, sy_lo, sy_hi);
  // the pixels whose centre lies in the sphere's exact bounding box on the image plane; the spare
  // covers the rounding of the box and of the ray-sphere test (~1e-4 pixel; near the eye 1e-2)
  constexpr float kSpare = 0.05f;
  PixelRect r;
  centre_range(m.pixel_x(sx_lo), m.pixel_x(sx_hi), kSpare, m.width, r.x0, r.x1);
  centre_range(m.pixel_y(sy_hi), m.pixel_y(sy_lo), kSpare, m.height, r.y0, r.y1);
  return r;
}

SphereHits no_hits(const Camera& camera) {
  SphereHits hits;
  hits.width = camera.width;
  hits.height = camera.height;
  const std::size_t pixels = static_cast<std::size_t>(camera.width) * static_cast<std::size_t>(camera.height);
  hits.t.assign(pixels, kInfinity);
  hits.id.assign(pixels, kNoSphere);
  return hits;
}

}  // namespace

std::size_t SphereHits::covered() const {
  std::size_t n = 0;
  for (auto i : id) n += i != kNoSphere;
  return n;
}

SphereHits splat_spheres(const ParticleSet& particles, const Camera& camera) { return splat_spheres(particles, spatial_order(particles), camera); }

SphereHits splat_spheres(const ParticleSet& particles, const SphereOrder& order, const Camera& camera) {
  const PrimaryRays m(camera);
  // everything per sphere is kept in the spatial order: item k is the sphere order.ids[k]
  std::vector<PixelRect> rects(order.size());
  std::vector<float> near_bound(order.size());  // no hit along a unit ray is nearer than |c − eye| − r
  parallel_for(order.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t k = begin; k < end; ++k) {
      const Sphere& s = order.spheres[k];
      rects[k] = particles.clip_of(order.ids[k]) == kSphereRemoved ? PixelRect{} : pixel_rect(m, s);
      const float distance = length(s.center - m.eye);
      near_bound[k] = lower_bound_with_margin(distance - s.radius, distance + s.radius);
    }
  }, 4096);
  const bool whole = particles.clip_state.empty();  // no sphere cut: each is met where its copy is
  SphereHits hits = no_hits(camera);
  // each tile's primary-ray directions, computed once rather than once per sphere
  struct TileRays {
    int x0, y0;
    std::array<Vec3, kRasterTile * kRasterTile> dir;
  };
  TileBins(rects, m.width, m.height).nearest_per_pixel(
      rects, near_bound, order.ids,
      [&](int x0, int y0, int x1, int y1) {
        auto rays = std::make_unique<TileRays>();
        rays->x0 = x0;
        rays->y0 = y0;
        for (int y = y0; y <= y1; ++y)
          for (int x = x0; x <= x1; ++x) rays->dir[static_cast<std::size_t>((y - y0) * kRasterTile + (x - x0))] = m.direction(x, y);
        return rays;
      },
      [&](const std::unique_ptr<TileRays>& rays, std::uint32_t k, int x, int y, float nearest) {
        const Ray ray{m.eye, rays->dir[static_cast<std::size_t>((y - rays->y0) * kRasterTile + (x - rays->x0))]};
        const float tmax = just_above(nearest);  // a tie is returned: it goes to the lower id
        return whole ? intersect_sphere(ray, order.spheres[k], 0, tmax) : intersect_particle(particles, order.ids[k], ray, 0, tmax);
      },
      [&](int x, int y, float t, std::uint32_t k) {
        const std::size_t i = static_cast<std::size_t>(y) * static_cast<std::size_t>(m.width) + static_cast<std::size_t>(x);
        hits.t[i] = t;
        hits.id[i] = k == TileBins::kNone ? kNoSphere : order.ids[k];
      });
  return hits;
}

SphereHits trace_spheres(const SphereBvh& bvh, const Camera& camera) {
  SphereHits hits = no_hits(camera);
  const PrimaryRays m(camera);
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
