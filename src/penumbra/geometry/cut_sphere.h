// Spheres cut by clip planes (core/clip_planes.h): the kept part of a sphere is the sphere less the
// half-spaces of the planes that cross it, a convex body bounded by the sphere's surface and a flat cap
// on each plane. A ray's hit is where it enters that body (on the sphere or on a cap), or where it
// leaves it when it starts inside; the cap is drawn in the sphere's colour with the plane's normal.
// Every sphere query of the renderer and the light structures goes through intersect_particle, so a
// cut sphere looks and casts the same everywhere.
#pragma once

#include <cmath>
#include <cstdint>

#include "penumbra/core/clip_planes.h"
#include "penumbra/data/particles.h"
#include "penumbra/geometry/sphere_bvh.h"

namespace penumbra {

// Both ends of the ray's chord through the sphere (t0 ≤ t1); false when the ray misses it. The roots
// are computed as in intersect_sphere (Haines et al.).
inline bool sphere_chord(const Ray& ray, const Sphere& s, float& t0, float& t1) {
  const Vec3 f = ray.origin - s.center;
  const float b = -dot(f, ray.direction);
  const Vec3 perp = f + ray.direction * b;
  const float r2 = s.radius * s.radius;
  const float disc = r2 - dot(perp, perp);
  if (disc < 0) return false;
  const float c = dot(f, f) - r2;
  const float q = b + std::copysign(std::sqrt(disc), b);
  t0 = q != 0 ? c / q : 0.0f;
  t1 = q;
  if (t0 > t1) std::swap(t0, t1);
  return true;
}

// The nearest t in (tmin, tmax) on the boundary of the sphere's kept part, or infinity.
inline float intersect_cut_sphere(const Ray& ray, const Sphere& s, const ClipPlanes& planes, SphereClip mask, float tmin,
                                  float tmax) {
  float t0, t1;
  if (!sphere_chord(ray, s, t0, t1) || !planes.keep(ray, t0, t1, mask)) return kInfinity;
  const float t = t0 > tmin ? t0 : t1;
  return (t > tmin && t < tmax) ? t : kInfinity;
}

// The outward normal of a cut sphere's kept part at a point p on its boundary: the cap's plane normal
// on a cap, else the sphere's.
inline Vec3 cut_sphere_normal(const Sphere& s, const ClipPlanes& planes, SphereClip mask, const Vec3& p) {
  const float on_cap = 1e-4f * s.radius;
  for (std::size_t i = 0; i < planes.size(); ++i)
    if ((mask & (1u << i)) && std::abs(planes.planes()[i].distance(p)) <= on_cap) return planes.planes()[i].normal;
  return normalize(p - s.center);
}

// The point of a cut sphere's kept part nearest to x (x itself when inside). One plane: exact — when
// the ball's nearest point lies beyond the plane, the nearest point of the kept part lies on the plane
// (its constraint is active), so it is x's projection onto the cap disk. Several planes: Dykstra's
// alternating projections onto the ball and each half-space, which converge to the same point
// (kDykstraRounds rounds: within a hundredth of the radius for the cuts tested).
inline Vec3 nearest_on_cut_sphere(const Vec3& x, const Sphere& s, const ClipPlanes& planes, SphereClip mask) {
  auto onto_ball = [&](const Vec3& p) {
    const Vec3 d = p - s.center;
    const float l = length(d);
    return l <= s.radius ? p : s.center + d * (s.radius / l);
  };
  int cutting = 0, only = -1;
  for (std::size_t i = 0; i < planes.size(); ++i)
    if (mask & (1u << i)) ++cutting, only = static_cast<int>(i);
  if (cutting == 1) {
    const ClipPlane& c = planes.planes()[static_cast<std::size_t>(only)];
    const Vec3 p = onto_ball(x);
    if (c.distance(p) <= 0) return p;
    const float h = c.distance(s.center);                       // < 0: the centre is kept
    const Vec3 disk_centre = s.center - c.normal * h;
    const float disk_radius = std::sqrt(std::max(s.radius * s.radius - h * h, 0.0f));
    const Vec3 in_plane = x - c.normal * c.distance(x);
    const Vec3 d = in_plane - disk_centre;
    const float l = length(d);
    return l <= disk_radius ? in_plane : disk_centre + d * (disk_radius / l);
  }
  constexpr int kDykstraRounds = 32;
  const std::size_t sets = planes.size() + 1;  // the ball, then the planes (those not cutting are skipped)
  Vec3 corrections[ClipPlanes::kMaxPlanes + 1] = {};
  Vec3 p = x;
  for (int round = 0; round < kDykstraRounds; ++round)
    for (std::size_t k = 0; k < sets; ++k) {
      if (k > 0 && !(mask & (1u << (k - 1)))) continue;
      const Vec3 y = p + corrections[k];
      Vec3 q = y;
      if (k == 0) {
        q = onto_ball(y);
      } else {
        const ClipPlane& c = planes.planes()[k - 1];
        const float d = c.distance(y);
        if (d > 0) q = y - c.normal * d;
      }
      corrections[k] = y - q;
      p = q;
    }
  return p;
}

// Sphere i of a set, whole, cut or removed as its clip state says.
inline float intersect_particle(const ParticleSet& set, std::size_t i, const Ray& ray, float tmin, float tmax) {
  const SphereClip c = set.clip_of(i);
  if (c == kSphereWhole) return intersect_sphere(ray, set.spheres[i], tmin, tmax);
  if (c == kSphereRemoved) return kInfinity;
  return intersect_cut_sphere(ray, set.spheres[i], set.clip_planes, c, tmin, tmax);
}

inline Vec3 particle_normal(const ParticleSet& set, std::size_t i, const Vec3& p) {
  const SphereClip c = set.clip_of(i);
  if (c == kSphereWhole || c == kSphereRemoved) return normalize(p - set.spheres[i].center);
  return cut_sphere_normal(set.spheres[i], set.clip_planes, c, p);
}

}  // namespace penumbra
