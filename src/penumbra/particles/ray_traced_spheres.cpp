#include "penumbra/particles/ray_traced_spheres.h"

#include <bit>
#include <cmath>

#include "penumbra/core/rng.h"

namespace penumbra {
namespace {

// A receiver's random rotation of the sample pattern (Cranley–Patterson), hashed from its position.
void rotation_of(const Vec3& p, float& r1, float& r2) {
  const std::uint64_t h = hash_keys(0x5eed, std::bit_cast<std::uint32_t>(p.x),
                                    std::bit_cast<std::uint32_t>(p.y), std::bit_cast<std::uint32_t>(p.z));
  r1 = to_unit_float(h);
  r2 = to_unit_float(mix64(h));
}

// Sample i of n on the unit square: a rotated Fibonacci lattice (stratified in both coordinates).
void lattice(int i, int n, float r1, float r2, float& u1, float& u2) {
  constexpr float kGolden = 0.618033988749895f;
  u1 = (static_cast<float>(i) + 0.5f) / static_cast<float>(n) + r1;
  u2 = static_cast<float>(i) * kGolden + r2;
  u1 -= std::floor(u1);
  u2 -= std::floor(u2);
}

// The share of `rays` rays from `origin` that no sphere blocks before tmax; ray i points along
// frame.to_world(local_direction(u1, u2)) for sample i of a rotated Fibonacci lattice keyed by `key`.
template <class Direction>
float unblocked_fraction(const SphereBvh& bvh, const Vec3& key, const Vec3& origin, const Frame& frame, int rays,
                         float tmax, Direction&& local_direction) {
  float r1, r2;
  rotation_of(key, r1, r2);
  int unblocked = 0;
  for (int i = 0; i < rays; ++i) {
    float u1, u2;
    lattice(i, rays, r1, r2, u1, u2);
    unblocked += bvh.occluded(Ray{origin, frame.to_world(local_direction(u1, u2))}, 0, tmax) ? 0 : 1;
  }
  return static_cast<float>(unblocked) / static_cast<float>(rays);
}

float scene_epsilon(const Box3& bounds) { return 1e-5f * std::max(1.0f, length(bounds.extent())); }

// Ray origin off a surface: Embree's sphere test loses precision for rays starting on the sphere, so
// the offset grows with the sphere (1/1000 of its radius).
Vec3 ray_origin(const SurfacePoint& sp, const ParticleSet& particles, float epsilon) {
  const float off = sp.self == kNoSphere ? epsilon : std::max(epsilon, 1e-3f * particles.spheres[sp.self].radius);
  return sp.position + sp.normal * off;
}

}  // namespace

void RayTracedSphereShadows::build(const ParticleScene& scene, const Light& light) {
  bvh_ = scene.bvh;
  particles_ = scene.particles;
  light_ = light;
  tan_light_radius_ = std::tan(radians(light_angle_deg_));
  epsilon_ = scene_epsilon(scene.bounds);
  scene_center_ = scene.bounds.empty() ? Vec3{0, 0, 0} : scene.bounds.center();
}

void RayTracedSphereShadows::light_fraction(std::span<const SurfacePoint> points, std::span<float> out) const {
  for (std::size_t k = 0; k < points.size(); ++k) {
    const SurfacePoint& sp = points[k];
    Vec3 to_light;
    float distance;
    light_.towards(sp.position, to_light, distance);
    const Vec3 origin = ray_origin(sp, *particles_, epsilon_);
    const float tmax = distance == kInfinity ? kInfinity : distance - epsilon_;
    if (light_angle_deg_ <= 0 || rays_ <= 1) {
      out[k] = bvh_->occluded(Ray{origin, to_light}, 0, tmax) ? 0.0f : 1.0f;
      continue;
    }
    // A round light: its angular radius is fixed for directional lights; point and spot lights are
    // balls whose radius subtends light_angle at the scene centre.
    float tan_radius = tan_light_radius_;
    if (light_.type != LightType::Directional && distance > 0)
      tan_radius = tan_light_radius_ * length(light_.position - scene_center_) / distance;
    const float cos_max = 1.0f / std::sqrt(1.0f + tan_radius * tan_radius);
    out[k] = unblocked_fraction(*bvh_, sp.position, origin, Frame::from_w(to_light), rays_, tmax, [&](float u1, float u2) {
      const float cos_t = 1.0f - u1 * (1.0f - cos_max);  // uniform over the cone's solid angle
      const float sin_t = std::sqrt(std::max(0.0f, 1.0f - cos_t * cos_t));
      const float phi = 2.0f * kPi * u2;
      return Vec3{sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t};
    });
  }
}

void RayTracedAmbientOcclusion::build(const ParticleScene& scene) {
  bvh_ = scene.bvh;
  particles_ = scene.particles;
  const Vec3 e = scene.bounds.empty() ? Vec3{1, 1, 1} : scene.bounds.extent();
  max_distance_ = max_distance_fraction_ * std::max(e.x, std::max(e.y, e.z));
  epsilon_ = scene_epsilon(scene.bounds);
}

void RayTracedAmbientOcclusion::ambient(std::span<const SurfacePoint> points, std::span<float> out) const {
  for (std::size_t k = 0; k < points.size(); ++k) {
    const SurfacePoint& sp = points[k];
    const Vec3 origin = ray_origin(sp, *particles_, epsilon_);
    out[k] = unblocked_fraction(*bvh_, sp.position, origin, Frame::from_w(sp.normal), rays_, max_distance_, [](float u1, float u2) {
      // cosine-weighted hemisphere (Malley): uniform on the disc, lifted
      const float r = std::sqrt(u1);
      const float phi = 2.0f * kPi * u2;
      return Vec3{r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0f, 1.0f - u1))};
    });
  }
}

}  // namespace penumbra
