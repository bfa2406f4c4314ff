#include "penumbra/shadows/shadow_map.h"

#include <algorithm>
#include <cstdint>

namespace penumbra {
namespace {

// The light depth where the opacity along `ray`, continuing from `transparency` (Π(1 − α_i) of what
// lies in front; colour plays no part in the classic map), first reaches the threshold; `surface`
// when it does not before it (or had already in front).
float threshold_crossing(const ShadowCasters& medium, const Ray& ray, float transparency, float surface) {
  float depth = surface;
  if (1 - transparency >= ClassicShadowMap::kOpacityThreshold) return depth;
  medium.march(ray, 0, surface, [&](const MediumSegment& s) {
    transparency *= 1 - s.alpha;
    if (1 - transparency >= ClassicShadowMap::kOpacityThreshold) {
      depth = s.t;
      return false;
    }
    return true;
  });
  return depth;
}

}  // namespace

void ClassicShadowMap::build_map(const ShadowCasters& medium) {
  depth_.assign(static_cast<std::size_t>(resolution_) * resolution_, kInfinity);
  if (const ShadowBrick* brick = medium.brick()) return build_brick(medium, *brick);
  for_each_texel([&](int ix, int iy, const Ray& ray) {
    depth_[texel_index(ix, iy)] = threshold_crossing(medium, ray, 1, first_surface(medium, ray));
  });
}

void ClassicShadowMap::build_brick(const ShadowCasters& medium, const ShadowBrick& brick) {
  // 1. this brick's transparency Π(1 − α_i) along each texel's ray, and which way the ray goes in z
  const std::size_t texels = depth_.size();
  std::vector<float> through(texels, 1.0f), surface(texels, kInfinity);
  std::vector<std::uint8_t> upwards(texels, 0);
  for_each_texel([&](int ix, int iy, const Ray& ray) {
    const std::size_t texel = texel_index(ix, iy);
    surface[texel] = first_surface(medium, ray);
    upwards[texel] = ray.direction.z >= 0 ? 1 : 0;
    float transparency = 1;
    medium.march(ray, 0, surface[texel], [&](const MediumSegment& s) {
      transparency *= 1 - s.alpha;
      return transparency > 0;
    });
    through[texel] = transparency;
  });
  // 2. the transparency of the bricks in front of this one, in the order each ray crosses them (the
  // same on every brick: the light projection is the whole scene's)
  std::vector<float> in_front_up, in_front_down;
  if (std::find(upwards.begin(), upwards.end(), 1) != upwards.end()) {
    in_front_up = through;
    brick.reduction->exclusive_product(in_front_up, true);
  }
  if (std::find(upwards.begin(), upwards.end(), 0) != upwards.end()) {
    in_front_down = through;
    brick.reduction->exclusive_product(in_front_down, false);
  }
  // 3. where the running product, continued through this brick, first reaches the threshold; the
  // nearest brick's crossing (or the surface) is the map's depth
  for_each_texel([&](int ix, int iy, const Ray& ray) {
    const std::size_t texel = texel_index(ix, iy);
    const float in_front = upwards[texel] ? in_front_up[texel] : in_front_down[texel];
    depth_[texel] = threshold_crossing(medium, ray, in_front, surface[texel]);
  });
  brick.reduction->minimum(depth_);
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

namespace {
const ParamSpec kPcfRadius = integer_param("pcf", 0, 0, 16, "texels", "percentage-closer filter radius r (0: off)");
}  // namespace

const TechniqueInfo& shadow_map_technique() {
  static const TechniqueInfo info{"shadow_map", TechniqueFamily::Shadow, kAllKinds,
                                  "classic shadow map: the depth where the opacity along a texel's ray reaches 0.5 (Williams)",
                                  {kMapResolution, kMapBias, kLightStep, kPcfRadius},
                                  {.sphere_rays = true},
                                  shadow_factory<ClassicShadowMap>(),
                                  {}};
  return info;
}

ClassicShadowMap::ClassicShadowMap(const TechniqueParams& params)
    : LightSpaceMap(params), pcf_(static_cast<int>(kPcfRadius.integer(params))) {
  filter_radius_ = pcf_;
}

}  // namespace penumbra
