// Colored stochastic shadow map for direct volume rendering (Weidner & Linsen, "Colored Stochastic
// Shadow Mapping for Direct Volume Rendering"; McGuire & Enderton 2011 for surfaces).
//
// Generation (paper Table 1): one photon per texel and colour channel walks the texel's ray; in
// segment i it is stopped with probability ρ_{i,λ} = α_i·(1 − t_{i,λ}) (§3), tested against one random
// number r_i per segment shared by the three channels; the texel stores per channel the depth of the
// first stop (c_λ = min(c_λ, z_i)). Opaque planes are written first, as the paper does for surfaces
// (§4). The walk ends early once all three channels are stopped.
// Look-up (Table 2): the shadow factor of channel λ is the fraction of m texels at offsets Δ_j whose
// c_λ lies behind the receiver. Its expected value is the exact transmittance Π_i(1 − ρ_{i,λ}).
//
// | parameter          | default         | meaning                                        |
// | shadows.resolution | 1024            | texels per side                                |
// | shadows.offsets    | 13              | m: 7, 13 (the paper's set) or 21               |
// | shadows.seed       | 1               | random numbers r_i = hash(seed, texel, segment) |
// | shadows.bias       | -1: one step    | world units                                    |
// | shadows.step       | -1: one voxel   | light-ray sampling step in voxels              |
// (declared with their ranges in cssm_technique(), cssm.cpp)
// Memory: resolution² · 3 floats.
#pragma once

#include <cstdint>
#include <span>
#include <utility>
#include <vector>

#include "penumbra/lighting/technique_info.h"
#include "penumbra/shadows/light_space_map.h"

namespace penumbra {

// The paper's 13 offsets {(0,0), (±3,±3), (±4,0), (0,±4), (±7,0), (0,±7)}, and the 7- and 21-offset
// variants (docs/techniques/cssm.md says how those were chosen).
std::span<const std::pair<int, int>> cssm_offsets(int count);

const TechniqueInfo& cssm_technique();

class ColoredStochasticShadowMap final : public LightSpaceMap {
public:
  using ShadowTechnique::transmittance;  // keep the one-point overload visible
  explicit ColoredStochasticShadowMap(const TechniqueParams& params);
  void transmittance(std::span<const Vec3> points, std::span<Rgb> out) const override;
  std::size_t memory_bytes() const override { return depth_.size() * sizeof(float); }
  std::string_view name() const override { return "cssm"; }
  // Per brick: the first stops among the brick's own segments (r_i keyed by texel and segment, the
  // same in every brick), combined by the per-channel minimum — the whole volume's map, bit for bit.
  bool combines_over_bricks() const override { return true; }
  // Stored first-stop depth of a channel (infinity: the photon was never stopped).
  float depth_at(int ix, int iy, int channel) const { return depth_[texel_index(ix, iy) * 3 + channel]; }

private:
  void build_map(const ShadowCasters& medium) override;
  std::uint64_t seed_;
  std::span<const std::pair<int, int>> offsets_;
  std::vector<std::ptrdiff_t> linear_offsets_;  // the offsets as distances in depth_ (floats)
  std::vector<float> depth_;  // [texel][channel]
};

}  // namespace penumbra
