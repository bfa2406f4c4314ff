// Clip planes (the scene's `clip_planes`, docs/scene-file.md): each plane removes the half-space its
// normal points into, {x : (x − point)·normal > 0}; what an object keeps is the intersection of the other
// sides, a convex region. Removed matter is gone for the eye and for every light: the renderer and every
// light structure ask the same three questions — is a point removed, which part of a ray is kept, is a
// sphere kept whole, removed whole or cut — so that a clipped object casts the shadow of what is left.
#pragma once

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include "penumbra/core/math.h"

namespace penumbra {

struct ClipPlane {
  Vec3 point;
  Vec3 normal;  // unit; points into the removed half-space

  float distance(const Vec3& p) const { return dot(p - point, normal); }  // > 0: removed
};

// A sphere against the clip planes: kept whole, removed whole, or cut (the mask of the planes that
// cross it; its kept part is the sphere less those half-spaces).
using SphereClip = std::uint8_t;
constexpr SphereClip kSphereWhole = 0;
constexpr SphereClip kSphereRemoved = 0x80;

class ClipPlanes {
public:
  static constexpr std::size_t kMaxPlanes = 6;  // enough for a box; a sphere's cut mask has a bit each

  ClipPlanes() = default;
  explicit ClipPlanes(std::vector<ClipPlane> planes) : planes_(std::move(planes)) {}

  bool empty() const { return planes_.empty(); }
  std::size_t size() const { return planes_.size(); }
  const std::vector<ClipPlane>& planes() const { return planes_; }

  bool removes(const Vec3& p) const {
    for (const ClipPlane& c : planes_)
      if (c.distance(p) > 0) return true;
    return false;
  }

  // Narrows [t0, t1] to the part of the ray the planes in `mask` keep (every plane by default); false
  // when nothing is kept.
  bool keep(const Ray& r, float& t0, float& t1, std::uint32_t mask = ~0u) const {
    for (std::size_t i = 0; i < planes_.size(); ++i) {
      if (!(mask & (1u << i))) continue;
      const ClipPlane& c = planes_[i];
      const float d0 = c.distance(r.origin), rate = dot(c.normal, r.direction);
      if (rate == 0) {
        if (d0 > 0) return false;
        continue;
      }
      const float t = -d0 / rate;  // where the ray crosses the plane
      if (rate > 0) t1 = std::min(t1, t);
      else t0 = std::max(t0, t);
      if (!(t0 < t1)) return false;
    }
    return true;
  }

  SphereClip classify(const Vec3& center, float radius) const {
    SphereClip mask = kSphereWhole;
    for (std::size_t i = 0; i < planes_.size(); ++i) {
      const float d = planes_[i].distance(center);
      if (d >= radius) return kSphereRemoved;
      if (d > -radius) mask = static_cast<SphereClip>(mask | (1u << i));
    }
    return mask;
  }

  // The fraction of a sphere's volume the planes of `mask` keep: the product of each plane's kept
  // part (exact for one plane: a spherical cap; for planes meeting inside the sphere an approximation).
  float kept_fraction(const Vec3& center, float radius, SphereClip mask) const {
    if (mask == kSphereRemoved) return 0;
    float kept = 1;
    for (std::size_t i = 0; i < planes_.size(); ++i) {
      if (!(mask & (1u << i))) continue;
      const float h = std::clamp(radius - planes_[i].distance(center), 0.0f, 2 * radius);  // height of the kept cap
      const float x = h / radius;
      kept *= x * x * (3 - x) / 4;  // cap volume π h² (3r − h) / 3 over 4π r³ / 3
    }
    return kept;
  }

private:
  std::vector<ClipPlane> planes_;
};

}  // namespace penumbra
