#include "penumbra/particles/implicit_sphere_shadow_map.h"

#include <atomic>
#include <bit>
#include <cmath>

#include "penumbra/core/parallel.h"

namespace penumbra {
namespace {

constexpr std::uint64_t kEmptyKey = ~std::uint64_t{0};

// Light-ray distances can be negative only below the map's near plane, which the fit keeps empty; the
// id breaks ties so that the map does not depend on the order the spheres are drawn in.
std::uint64_t depth_key(float t, std::uint32_t id) {
  return (static_cast<std::uint64_t>(std::bit_cast<std::uint32_t>(std::max(t, 0.0f))) << 32) | id;
}

int floor_int(float v) {
  const int i = static_cast<int>(v);
  return i - (static_cast<float>(i) > v ? 1 : 0);
}

}  // namespace

void ImplicitSphereShadowMap::build(const ParticleScene& scene, const Light& light) {
  particles_ = scene.particles;
  light_ = light;
  projection_ = LightProjection::fit(light, scene.bounds);
  const int n = params_.resolution;
  const auto nn = static_cast<std::size_t>(n) * static_cast<std::size_t>(n);
  std::vector<std::atomic<std::uint64_t>> keys(nn);
  for (auto& k : keys) k.store(kEmptyKey, std::memory_order_relaxed);
  const float fn = static_cast<float>(n);
  // the smallest texel of the map: at the near side for a perspective light
  const float texel = projection_.texel_size(std::max(projection_.near_depth(), 1e-6f), n);
  soft_rings_ = params_.soft_radius > 0 ? static_cast<int>(std::ceil(params_.soft_radius / texel)) : 0;

  // §3 generation: every sphere covers the texels whose centre ray hits it.
  parallel_for(particles_->size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const Sphere& s = particles_->spheres[i];
      float u_lo = kInfinity, u_hi = -kInfinity, v_lo = kInfinity, v_hi = -kInfinity;
      if (!projection_.perspective()) {  // parallel light: the disc of radius r around the centre
        float u, v, depth;
        projection_.project(s.center, u, v, depth);
        const float ru = s.radius * projection_.map_scale();
        u_lo = u - ru; u_hi = u + ru; v_lo = v - ru; v_hi = v + ru;
      } else {  // the map rectangle of the sphere's bounding cube
        bool behind = false;
        for (int c = 0; c < 8; ++c) {
          const Vec3 corner = s.center + Vec3{(c & 1) ? s.radius : -s.radius, (c & 2) ? s.radius : -s.radius,
                                              (c & 4) ? s.radius : -s.radius};
          float u = std::nanf(""), v = std::nanf(""), depth = -1;
          projection_.project(corner, u, v, depth);
          if (!std::isfinite(u) || !std::isfinite(v) || depth <= 0) behind = true;
          u_lo = std::min(u_lo, u); u_hi = std::max(u_hi, u);
          v_lo = std::min(v_lo, v); v_hi = std::max(v_hi, v);
        }
        if (behind) continue;
      }
      // texel k's centre is at u = (k + 0.5)/n; clamped before the integer floor (no libm call, no
      // overflow for spheres far off the map)
      const int i0 = std::max(0, floor_int(clamp(u_lo * fn - 0.5f, -2.0f, fn + 1)));
      const int i1 = std::min(n - 1, floor_int(clamp(u_hi * fn - 0.5f, -2.0f, fn + 1)) + 1);
      const int j0 = std::max(0, floor_int(clamp(v_lo * fn - 0.5f, -2.0f, fn + 1)));
      const int j1 = std::min(n - 1, floor_int(clamp(v_hi * fn - 0.5f, -2.0f, fn + 1)) + 1);
      const auto id = static_cast<std::uint32_t>(i);
      auto keep_nearest = [&](int k, int j, float t) {
        auto& slot = keys[static_cast<std::size_t>(j) * static_cast<std::size_t>(n) + static_cast<std::size_t>(k)];
        const std::uint64_t key = depth_key(t, id);
        std::uint64_t cur = slot.load(std::memory_order_relaxed);
        while (key < cur && !slot.compare_exchange_weak(cur, key, std::memory_order_relaxed)) {
        }
      };
      if (!projection_.perspective()) {
        // parallel rays: the texel ray at map distance ρ from the centre enters the sphere at
        // depth(centre) − sqrt(r² − ρ²)
        float u, v, depth;
        projection_.project(s.center, u, v, depth);
        const float world_per_u = 1.0f / projection_.map_scale();
        const float r2 = s.radius * s.radius;
        for (int j = j0; j <= j1; ++j) {
          const float dv = ((static_cast<float>(j) + 0.5f) / fn - v) * world_per_u;
          for (int k = i0; k <= i1; ++k) {
            const float du = ((static_cast<float>(k) + 0.5f) / fn - u) * world_per_u;
            const float h2 = r2 - du * du - dv * dv;
            if (h2 >= 0) keep_nearest(k, j, depth - std::sqrt(h2));
          }
        }
        continue;
      }
      for (int j = j0; j <= j1; ++j)
        for (int k = i0; k <= i1; ++k) {
          const Ray ray = projection_.texel_ray((static_cast<float>(k) + 0.5f) / fn, (static_cast<float>(j) + 0.5f) / fn);
          const float t = intersect_sphere(ray, s, -kInfinity, kInfinity);
          if (t != kInfinity) keep_nearest(k, j, t);
        }
    }
  }, 1024);

  map_.assign(nn, kNoSphere);
  for (std::size_t i = 0; i < nn; ++i) {
    const std::uint64_t k = keys[i].load(std::memory_order_relaxed);
    if (k != kEmptyKey) map_[i] = static_cast<std::uint32_t>(k & 0xFFFFFFFFu);
  }
}

float ImplicitSphereShadowMap::light_at(const SurfacePoint& p) const {
  float u, v, depth;
  if (!projection_.project(p.position, u, v, depth)) return 1.0f;  // outside the map: nothing casts
  Vec3 to_light;
  float light_distance;
  light_.towards(p.position, to_light, light_distance);
  const int n = params_.resolution;
  const int ci = std::min(n - 1, static_cast<int>(u * static_cast<float>(n)));
  const int cj = std::min(n - 1, static_cast<int>(v * static_cast<float>(n)));
  const int t = rings();
  const bool soft = params_.soft_radius > 0;
  float light = 1.0f;
  for (int j = std::max(0, cj - t); j <= std::min(n - 1, cj + t); ++j) {
    for (int i = std::max(0, ci - t); i <= std::min(n - 1, ci + t); ++i) {
      const std::uint32_t id = texel(i, j);
      if (id == kNoSphere || id == p.self) continue;
      const Sphere& s = particles_->spheres[id];
      // Fig. 4: k is the distance along the shadow ray to the plane through the centre normal to it,
      // d the distance from that point to the centre, s' = d − r the ray's clearance of the surface.
      const Vec3 oc = s.center - p.position;
      const float k = dot(oc, to_light);
      if (k <= 0 || k >= light_distance) continue;  // behind the receiver or beyond the light
      const float d = std::sqrt(std::max(dot(oc, oc) - k * k, 0.0f));
      const float clearance = d - s.radius;
      if (clearance <= 0) return 0.0f;  // the shadow ray hits the sphere
      if (!soft) continue;
      const float kb = k / params_.soft_distance;
      const float grown = params_.soft_radius * (1.0f - std::exp(-4.5f * kb * kb));
      if (clearance >= grown) continue;
      const float strength = std::pow(1.0f - clearance / grown, params_.soft_exponent);
      light = std::min(light, 1.0f - strength);
    }
  }
  return light;
}

void ImplicitSphereShadowMap::light_fraction(std::span<const SurfacePoint> points, std::span<float> out) const {
  for (std::size_t i = 0; i < points.size(); ++i) out[i] = light_at(points[i]);
}

}  // namespace penumbra
