#include "penumbra/scene/light_projection.h"

#include <cmath>
#include <string>

#include "penumbra/core/error.h"

namespace penumbra {

LightProjection LightProjection::fit(const Light& light, const Box3& bounds_in) {
  Box3 bounds = bounds_in;
  if (bounds.empty()) bounds = Box3{{-1, -1, -1}, {1, 1, 1}};
  // A little margin so that the outermost casters are not on the map's border texels.
  const Vec3 pad = bounds.extent() * 0.01f + Vec3{1e-6f, 1e-6f, 1e-6f};
  bounds = Box3{bounds.lo - pad, bounds.hi + pad};
  LightProjection p;
  if (light.type == LightType::Directional) {
    p.frame_ = Frame::from_w(light.direction);
    float lo_u = kInfinity, hi_u = -kInfinity, lo_v = kInfinity, hi_v = -kInfinity, lo_w = kInfinity, hi_w = -kInfinity;
    for (int i = 0; i < 8; ++i) {
      const Vec3 l = p.frame_.to_local(bounds.corner(i));
      lo_u = std::min(lo_u, l.x); hi_u = std::max(hi_u, l.x);
      lo_v = std::min(lo_v, l.y); hi_v = std::max(hi_v, l.y);
      lo_w = std::min(lo_w, l.z); hi_w = std::max(hi_w, l.z);
    }
    // Square texels: one window size for both axes.
    const float size = std::max(hi_u - lo_u, hi_v - lo_v);
    p.origin_ = p.frame_.w * lo_w;
    p.lo_u_ = 0.5f * (lo_u + hi_u) - 0.5f * size;
    p.lo_v_ = 0.5f * (lo_v + hi_v) - 0.5f * size;
    p.inv_u_ = p.inv_v_ = 1.0f / size;
    p.near_ = 0;
    p.far_ = hi_w - lo_w;
    return p;
  }
  p.perspective_ = true;
  p.origin_ = light.position;
  const Vec3 axis = bounds.center() - light.position;
  if (length(axis) < 1e-12f || bounds.contains(light.position))
    throw Error("the " + to_string(light.type) +
                " light is inside the scene's bounds: a single shadow-map frustum cannot cover the scene "
                "(use shadows.technique=ray_traced, or move the light outside)");
  p.frame_ = Frame::from_w(axis);
  float max_tan = 0, near = kInfinity, far = 0;
  for (int i = 0; i < 8; ++i) {
    const Vec3 l = p.frame_.to_local(bounds.corner(i) - light.position);
    if (l.z <= 0) max_tan = kInfinity;
    else max_tan = std::max(max_tan, std::max(std::abs(l.x), std::abs(l.y)) / l.z);
    near = std::min(near, length(bounds.corner(i) - light.position));
    far = std::max(far, length(bounds.corner(i) - light.position));
  }
  if (!(max_tan <= std::tan(radians(kMaxHalfAngleDeg))))
    throw Error("the " + to_string(light.type) + " light is too close to the scene: its shadow frustum would need a half-angle above " +
                std::to_string(static_cast<int>(kMaxHalfAngleDeg)) +
                " degrees (use shadows.technique=ray_traced, or move the light further away)");
  p.tan_half_ = max_tan;
  p.near_ = near;
  p.far_ = far;
  return p;
}

}  // namespace penumbra
