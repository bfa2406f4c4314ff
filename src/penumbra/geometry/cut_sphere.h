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
