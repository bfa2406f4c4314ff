// Classic shadow map for volumes (the CSSM paper's baseline, §4): one depth per texel, the light depth
// where the accumulated opacity along the texel's ray first reaches 0.5; a receiver is lit when it is
// nearer than that depth (minus the bias). Optional percentage-closer filtering over (2r+1)² texels.
// Built per brick on MPI ranks (accel/brick_reduction.h) from the combined transparency: the crossing
// is the same segment as in one process unless the running product lands within rounding of 0.5 (the
// bricks' partial products are multiplied in another order).
//
// | parameter          | default          | meaning                                   |
// | shadows.resolution | 1024             | texels per side                           |
// | shadows.bias       | one shadow step  | world units subtracted from receiver depth |
// | shadows.pcf        | 0                | PCF radius r in texels                    |
#pragma once

#include <vector>

#include "penumbra/lighting/technique_info.h"
#include "penumbra/shadows/light_space_map.h"

namespace penumbra {

const TechniqueInfo& shadow_map_technique();

class ClassicShadowMap final : public LightSpaceMap {
public:
  using ShadowTechnique::transmittance;  // keep the one-point overload visible
  static constexpr float kOpacityThreshold = 0.5f;
  explicit ClassicShadowMap(const TechniqueParams& params);
  void transmittance(std::span<const Vec3> points, std::span<Rgb> out) const override;
  std::size_t memory_bytes() const override { return depth_.size() * sizeof(float); }
  std::string_view name() const override { return "shadow_map"; }
  // Per brick: each brick's transparency along a texel's ray, the product of the bricks in front of it,
  // then each brick's crossing of 0.5 continued from that product; the nearest crossing is the map's.
  bool combines_over_bricks() const override { return true; }
  float depth_at(int ix, int iy) const { return depth_[texel_index(ix, iy)]; }

private:
  void build_map(const ShadowCasters& medium) override;
  void build_brick(const ShadowCasters& medium, const ShadowBrick& brick);
  int pcf_;
  std::vector<float> depth_;
};

}  // namespace penumbra
