#include "penumbra/isosurface/ray_traced_isosurface.h"

#include <algorithm>

namespace penumbra {

void RayTracedIsosurfaceShadows::build(const IsoShadowInputs& in, const Light& light) {
  raycaster_ = std::make_unique<IsosurfaceRaycaster>(*in.tree, in.isovalue);
  light_ = light;
  const Vec3& s = in.tree->volume().spacing();
  // Far enough off the surface that float rounding of a point at hundreds of voxels from the origin
  // cannot put the start behind its own surface; small against any feature.
  offset_ = 0.05f * std::min({s.x, s.y, s.z});
}

void RayTracedIsosurfaceShadows::light_fraction(std::span<const IsoPoint> points, std::span<float> out) const {
  for (std::size_t i = 0; i < points.size(); ++i) {
    const IsoPoint& p = points[i];
    Vec3 to_light;
    float distance;
    light_.towards(p.position, to_light, distance);
    const Vec3 n = dot(p.normal, to_light) >= 0 ? p.normal : -p.normal;
    const Ray ray{p.position + n * offset_, to_light};
    out[i] = raycaster_->first_hit(ray, 0, distance) < kInfinity ? 0.0f : 1.0f;
  }
}

}  // namespace penumbra
