#include "penumbra/shadows/shadow_map.h"

namespace penumbra {

void ClassicShadowMap::build_map(const ShadowCasters& medium) {
  depth_.assign(static_cast<std::size_t>(resolution_) * resolution_, kInfinity);
  for_each_texel([&](int ix, int iy, const Ray& ray) {
    float depth = first_surface(medium, ray);
    float transparency = 1;  // Π(1 − α_i): colour plays no part in the classic map
    medium.march(ray, 0, depth, [&](const MediumSegment& s) {
      transparency *= 1 - s.alpha;
      if (1 - transparency >= kOpacityThreshold) {
        depth = s.t;
        return false;
      }
      return true;
    });
    depth_[texel_index(ix, iy)] = depth;
  });
}

void ClassicShadowMap::transmittance(std::span<const Vec3> points, std::span<Rgb> out) const {
  query(points, out, [&](int ix, int iy, float depth) {
    int lit = 0, total = 0;
    for (int dy = -pcf_; dy <= pcf_; ++dy)
      for (int dx = -pcf_; dx <= pcf_; ++dx) {
        const int x = std::clamp(ix + dx, 0, resolution_ - 1), y = std::clamp(iy + dy, 0, resolution_ - 1);
        lit += depth <= depth_[texel_index(x, y)] ? 1 : 0;
        ++total;
      }
    return Rgb(static_cast<float>(lit) / static_cast<float>(total));
  });
}

}  // namespace penumbra
