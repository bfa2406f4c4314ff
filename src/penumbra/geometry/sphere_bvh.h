// Embree 3's BVH over a ParticleSet's spheres (RTC_GEOMETRY_TYPE_SPHERE_POINT, reading the set's
// packed x, y, z, r in place): exact nearest hits and occlusion queries for the sphere renderer's
// Embree path and the ray-traced references (shadow rays, ambient-occlusion rays). Spheres that clip
// planes cut are a user geometry intersected exactly (geometry/cut_sphere.h); removed ones are not hit.
#pragma once

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>

#include "penumbra/core/math.h"
#include "penumbra/data/particles.h"

namespace penumbra {


struct SphereHit {
  float t = kInfinity;
  std::uint32_t id = kNoSphere;
};

class SphereBvh {
public:
  explicit SphereBvh(const ParticleSet& particles);  // particles must outlive the BVH
  ~SphereBvh();
  SphereBvh(const SphereBvh&) = delete;
  SphereBvh& operator=(const SphereBvh&) = delete;

  // Nearest sphere along the ray with t in (tmin, tmax); id kNoSphere when none.
  SphereHit first_hit(const Ray& ray, float tmin, float tmax) const;
  // Whether any sphere crosses the ray within (tmin, tmax).
  bool occluded(const Ray& ray, float tmin, float tmax) const;
  double build_ms() const { return build_ms_; }
  std::size_t memory_bytes() const;  // what Embree allocated for the BVH (its memory monitor)

private:
  void* device_ = nullptr;  // RTCDevice
  void* scene_ = nullptr;   // RTCScene
  double build_ms_ = 0;
  std::shared_ptr<void> cut_spheres_;  // the cut spheres' geometry data, while the scene uses it
  std::unique_ptr<std::atomic<std::int64_t>> allocated_ = std::make_unique<std::atomic<std::int64_t>>(0);
};

// Exact ray–sphere intersection: the nearest t in (tmin, tmax) or infinity. The discriminant comes from
// the ray's perpendicular distance to the centre and the roots from c/q and q, which keeps hits far from
// the ray origin precise (Haines et al., "Precision Improvements for Ray/Sphere Intersection", Ray
// Tracing Gems 2019, ch. 7); the textbook b² − c loses the last digits that shading needs.
inline float intersect_sphere(const Ray& ray, const Sphere& s, float tmin, float tmax) {
  const Vec3 f = ray.origin - s.center;
  const float b = -dot(f, ray.direction);
  const Vec3 perp = f + ray.direction * b;
  const float r2 = s.radius * s.radius;
  const float disc = r2 - dot(perp, perp);
  if (disc < 0) return kInfinity;
  const float c = dot(f, f) - r2;
  const float q = b + std::copysign(std::sqrt(disc), b);
  float t0 = q != 0 ? c / q : 0.0f, t1 = q;
  if (t0 > t1) std::swap(t0, t1);
  const float t = t0 > tmin ? t0 : t1;
  return (t > tmin && t < tmax) ? t : kInfinity;
}

}  // namespace penumbra
