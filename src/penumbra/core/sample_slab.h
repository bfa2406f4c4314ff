// The samples one brick of a sort-last decomposition owns (distributed/volume_slabs.h): those at world
// z_lo ≤ z < z_hi, so that every sample of a ray's lattice lies in exactly one brick — the eye's ray
// casting samples (render/volume_raycaster.h) and the light's march segments (lighting/shadow_casters.h)
// alike, each judged at the point where it is classified.
#pragma once

#include <algorithm>

#include "penumbra/core/math.h"

namespace penumbra {

struct SampleSlab {
  float z_lo = -kInfinity, z_hi = kInfinity;
  bool owns(const Vec3& p) const { return p.z >= z_lo && p.z < z_hi; }
  bool whole() const { return z_lo == -kInfinity && z_hi == kInfinity; }
  // [t0, t1] narrowed to where the ray crosses the slab, widened by `margin` on each side so that no
  // owned sample is lost to rounding (owns() decides each sample); false when the ray misses it.
  bool clip(const Ray& ray, float margin, float& t0, float& t1) const {
    if (ray.direction.z == 0) return ray.origin.z >= z_lo && ray.origin.z < z_hi;
    const float a = (z_lo - ray.origin.z) / ray.direction.z, b = (z_hi - ray.origin.z) / ray.direction.z;
    t0 = std::max(t0, std::min(a, b) - margin);
    t1 = std::min(t1, std::max(a, b) + margin);
    return t0 <= t1;
  }
};

}  // namespace penumbra
