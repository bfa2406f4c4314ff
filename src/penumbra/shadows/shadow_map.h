// Classic shadow map for volumes (the CSSM paper's baseline, §4): one depth per texel, the light depth
// where the accumulated opacity along the texel's ray first reaches 0.5; a receiver is lit when it is
// nearer than that depth (minus the bias). Optional percentage-closer filtering over (2r+1)² texels.
//
// | parameter          | default          | meaning                                   |
// | shadows.resolution | 1024             | texels per side                           |
// | shadows.bias       | one shadow step  | world units subtracted from receiver depth |
// | shadows.pcf        | 0                | PCF radius r in texels                    |
#pragma once

#include <vector>

#include "penumbra/shadows/light_space_map.h"

namespace penumbra {

class ClassicShadowMap final : public LightSpaceMap {
public:
  using ShadowTechnique::transmittance;  // keep the one-point overload visible
  static constexpr float kOpacityThreshold = 0.5f;
  explicit ClassicShadowMap(const ShadowSettings& s) : LightSpaceMap(s), pcf_(s.pcf) { filter_radius_ = s.pcf; }
  void transmittance(std::span<const Vec3> points, std::span<Rgb> out) const override;
  std::size_t memory_bytes() const override { return depth_.size() * sizeof(float); }
  std::string_view name() const override { return "shadow_map"; }
  float depth_at(int ix, int iy) const { return depth_[texel_index(ix, iy)]; }

private:
  void build_map(const ShadowCasters& medium) override;
  int pcf_;
  std::vector<float> depth_;
};

}  // namespace penumbra
