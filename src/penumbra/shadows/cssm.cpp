#include "penumbra/shadows/cssm.h"

#include <array>
#include <cstdint>

#include "penumbra/core/error.h"
#include "penumbra/core/rng.h"

namespace penumbra {
namespace {
// Ordered so that the first 7 are the paper's centre, its four axis offsets at 4 and two opposite
// diagonals (a centrally symmetric subset of the 13), and the last 8 extend the 13 with larger rings.
constexpr std::array<std::pair<int, int>, 21> kOffsets{{
    {0, 0}, {4, 0}, {-4, 0}, {0, 4}, {0, -4}, {3, 3}, {-3, -3},          // 7
    {3, -3}, {-3, 3}, {7, 0}, {-7, 0}, {0, 7}, {0, -7},                  // 13: the paper's set
    {5, 5}, {-5, -5}, {5, -5}, {-5, 5}, {10, 0}, {-10, 0}, {0, 10}, {0, -10}  // 21
}};
}  // namespace

std::span<const std::pair<int, int>> cssm_offsets(int count) {
  if (count != 7 && count != 13 && count != 21)
    throw Error("cssm offsets " + std::to_string(count) + " (expected 7, 13 or 21)");
  return std::span<const std::pair<int, int>>(kOffsets.data(), static_cast<std::size_t>(count));
}

namespace {

const ParamSpec kOffsetCount = [] {
  ParamSpec p = integer_param("offsets", 13, 7, 21, "", "m, the look-up offsets averaged per channel: 7, 13 (the paper's set) or 21");
  p.only = {7, 13, 21};
  return p;
}();
const ParamSpec kSeed = integer_param("seed", 1, 0, std::int64_t{1} << 53, "", "random numbers r_i = hash(seed, texel, segment)", ParamRole::Seed);

}  // namespace

const TechniqueInfo& cssm_technique() {
  static const TechniqueInfo info{"cssm", TechniqueFamily::Shadow, kAllKinds,
                                  "coloured stochastic shadow map: one photon per texel and channel (Weidner & Linsen)",
                                  {kMapResolution, kMapBias, kLightStep, kOffsetCount, kSeed},
                                  {.sphere_rays = true},
                                  shadow_factory<ColoredStochasticShadowMap>(),
                                  {}};
  return info;
}

ColoredStochasticShadowMap::ColoredStochasticShadowMap(const TechniqueParams& params)
    : LightSpaceMap(params), seed_(static_cast<std::uint64_t>(kSeed.integer(params))),
      offsets_(cssm_offsets(static_cast<int>(kOffsetCount.integer(params)))) {
  for (const auto& o : offsets_) {
    filter_radius_ = std::max(filter_radius_, std::max(std::abs(o.first), std::abs(o.second)));
    linear_offsets_.push_back((static_cast<std::ptrdiff_t>(o.second) * resolution_ + o.first) * 3);
  }
}

void ColoredStochasticShadowMap::build_map(const ShadowCasters& medium) {
  depth_.assign(static_cast<std::size_t>(resolution_) * resolution_ * 3, kInfinity);
  for_each_texel([&](int ix, int iy, const Ray& ray) {
    const std::size_t texel = texel_index(ix, iy);
    // Surfaces first (§4): an opaque plane stops every photon.
    const float surface = first_surface(medium, ray);
    float c[3] = {surface, surface, surface};
    const RandomStream random(seed_, texel);  // r_i keyed by (seed, texel, segment index)
    // Table 1. Segments beyond the surface cannot lower a stored minimum, so the walk ends there.
    medium.march(ray, 0, surface, [&](const MediumSegment& s) {
      const float r = random(static_cast<std::uint64_t>(s.index));
      bool all_stopped = true;
      for (int l = 0; l < 3; ++l) {
        const float rho = s.alpha * (1.0f - s.transmission[l]);
        if (rho > r) c[l] = std::min(c[l], s.t);
        all_stopped = all_stopped && c[l] <= s.t;
      }
      return !all_stopped;  // early exit once every channel's photon is stopped (nothing deeper can lower c)
    });
    for (int l = 0; l < 3; ++l) depth_[texel * 3 + l] = c[l];
  });
  if (const ShadowBrick* brick = medium.brick()) brick->reduction->minimum(depth_);
}

void ColoredStochasticShadowMap::transmittance(std::span<const Vec3> points, std::span<Rgb> out) const {
  const float weight = 1.0f / static_cast<float>(offsets_.size());
  query(points, out, [&](int ix, int iy, float depth) {
    int lit[3] = {0, 0, 0};  // Table 2, counted; l_λ = count / m
    const bool interior = ix >= filter_radius_ && iy >= filter_radius_ && ix < resolution_ - filter_radius_ &&
                          iy < resolution_ - filter_radius_;
    if (interior) {  // the common case: every offset inside the map, no clamping
      const float* centre = &depth_[texel_index(ix, iy) * 3];
      for (const std::ptrdiff_t d : linear_offsets_) {
        const float* c = centre + d;
        lit[0] += c[0] > depth;
        lit[1] += c[1] > depth;
        lit[2] += c[2] > depth;
      }
    } else {
      for (const auto& [dx, dy] : offsets_) {
        const int x = std::clamp(ix + dx, 0, resolution_ - 1), y = std::clamp(iy + dy, 0, resolution_ - 1);
        const float* c = &depth_[texel_index(x, y) * 3];
        for (int l = 0; l < 3; ++l) lit[l] += c[l] > depth;
      }
    }
    return Rgb(static_cast<float>(lit[0]) * weight, static_cast<float>(lit[1]) * weight, static_cast<float>(lit[2]) * weight);
  });
}

}  // namespace penumbra
