#include "penumbra/shadows/light_space_map.h"

#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"

namespace penumbra {

void LightSpaceMap::build(const ShadowCasters& medium, const Light& light) {
  light_ = light;
  projection_ = LightProjection::fit(light, medium.bounds());
  // Default bias: one shadow step, the depth extent of one segment (a sample must not shadow itself).
  bias_ = bias_setting_ >= 0 ? bias_setting_ : medium.step();
  build_map(medium);
}

void LightSpaceMap::for_each_texel(const std::function<void(int, int, const Ray&)>& texel) const {
  const float inv = 1.0f / static_cast<float>(resolution_);
  Progress progress(std::string(name()) + " build", static_cast<std::size_t>(resolution_));
  parallel_for(static_cast<std::size_t>(resolution_), [&](std::size_t y0, std::size_t y1) {
    for (std::size_t iy = y0; iy < y1; ++iy) {
      for (int ix = 0; ix < resolution_; ++ix)
        texel(ix, static_cast<int>(iy),
              projection_.texel_ray((static_cast<float>(ix) + 0.5f) * inv, (static_cast<float>(iy) + 0.5f) * inv));
      progress.advance();
    }
  });
}

Vec3 LightSpaceMap::surface_receiver(const Vec3& p, const Vec3& n) const {
  Vec3 to_light;
  float distance;
  light_.towards(p, to_light, distance);
  float u, v, depth;
  if (!projection_.project(p, u, v, depth)) return p;
  // The surface's depth changes by texel·tanθ across one texel (θ between normal and light); a query
  // that reads texels up to filter_radius_ away sees the surface that much nearer. Move the receiver
  // that far (plus a texel's margin) towards the light, capped at grazing angles.
  const float cos_theta = std::max(std::abs(dot(n, to_light)), 0.05f);
  const float tan_theta = std::sqrt(1.0f - cos_theta * cos_theta) / cos_theta;
  const float texel = projection_.texel_size(depth, resolution_);
  const float offset = texel * (1.5f + (1.5f + static_cast<float>(filter_radius_)) * tan_theta);
  return p + to_light * offset;
}

}  // namespace penumbra
