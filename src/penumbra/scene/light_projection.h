// The light's view of the scene for shadow maps: orthographic for directional lights, perspective for
// point and spot lights, fitted to the casters' bounds. Map coordinates (u, v) are in [0, 1]²; the depth
// of a point is its distance along the light ray through it (from the light's near plane for
// orthographic maps, from the light's position for perspective ones), so a texel's ray parameter and
// a receiver's depth are directly comparable.
#pragma once

#include "penumbra/core/math.h"
#include "penumbra/scene/light.h"

namespace penumbra {

class LightProjection {
public:
  // Throws Error when a point or spot light is inside or too close to the bounds for one frustum
  // (half-angle above kMaxHalfAngleDeg).
  static LightProjection fit(const Light& light, const Box3& bounds);
  static constexpr float kMaxHalfAngleDeg = 80.0f;

  // Map coordinates and depth of p; false when p is outside the map (or behind a perspective light).
  bool project(const Vec3& p, float& u, float& v, float& depth) const {
    if (!perspective_) {
      const Vec3 l = frame_.to_local(p - origin_);
      u = (l.x - lo_u_) * inv_u_;
      v = (l.y - lo_v_) * inv_v_;
      depth = l.z;
    } else {
      const Vec3 d = p - origin_;
      const Vec3 l = frame_.to_local(d);
      if (l.z <= 1e-12f) return false;
      u = 0.5f + 0.5f * l.x / (l.z * tan_half_);
      v = 0.5f + 0.5f * l.y / (l.z * tan_half_);
      depth = length(d);
    }
    return u >= 0 && u <= 1 && v >= 0 && v <= 1;
  }

  // The light ray through map point (u, v); its parameter t equals project()'s depth.
  Ray texel_ray(float u, float v) const {
    if (!perspective_)
      return Ray{origin_ + frame_.u * (lo_u_ + u / inv_u_) + frame_.v * (lo_v_ + v / inv_v_), frame_.w};
    const Vec3 d = frame_.u * ((2 * u - 1) * tan_half_) + frame_.v * ((2 * v - 1) * tan_half_) + frame_.w;
    return Ray{origin_, normalize(d)};
  }

  // World size of one texel of an n x n map at depth `depth` (for slope-scaled bias).
  float texel_size(float depth, int n) const {
    return perspective_ ? 2.0f * tan_half_ * depth / static_cast<float>(n)
                        : std::max(1.0f / inv_u_, 1.0f / inv_v_) / static_cast<float>(n);
  }
  bool perspective() const { return perspective_; }
  // Orthographic maps: map units (u, v) per world unit (the same on both axes).
  float map_scale() const { return inv_u_; }
  // Where opaque casters begin along a texel ray. A directional light has no "behind": every caster
  // on the texel's whole line shadows what lies beyond it, including a plane on the light's side of
  // the fitted bounds (at negative depth). A point or spot light casts only forwards from its position.
  float caster_t_begin() const { return perspective_ ? 0.0f : -kInfinity; }
  // Depth range [near, far] of the casters' bounds.
  float near_depth() const { return near_; }
  float far_depth() const { return far_; }

private:
  bool perspective_ = false;
  Frame frame_;
  Vec3 origin_;
  float lo_u_ = 0, lo_v_ = 0, inv_u_ = 1, inv_v_ = 1;  // orthographic window
  float tan_half_ = 1;                                  // perspective half-angle
  float near_ = 0, far_ = 1;
};

}  // namespace penumbra
