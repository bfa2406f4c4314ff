// Deep shadow map for volumes (Lokovic & Veach 2000; the CSSM paper's baseline with 3 nodes per colour
// channel, §4): per texel and colour channel a piecewise-linear transmittance function T_λ(z) of at
// most N nodes (z_j, T_j); T = 1 before the first node, constant after the last.
//
// Compression rule (the papers leave it open; docs/techniques/deep_shadow_map.md): the exact function
// along the texel's ray is a polyline with a vertex at each absorbing segment's end. Start from its
// first and last vertices and repeatedly insert the vertex farthest (in T) from the current
// piecewise-linear approximation, until N nodes are used or the error is below 1e-4 (greedy
// Douglas–Peucker insertion). It keeps both ends exact and places interior nodes where T bends most.
//
// | parameter          | default         | meaning                      |
// | shadows.resolution | 1024            | texels per side              |
// | shadows.nodes      | 3               | nodes per colour channel, N  |
// | shadows.bias       | one shadow step | world units                  |
// Opaque planes are not folded into the function (with few nodes, the vertical drop to zero would
// pull the interpolated T down well before the surface); each texel keeps the depth of its first
// opaque surface, as a classic shadow map does, and T = 0 beyond it.
// Memory: resolution² · (3 channels · N nodes · (depth, T) floats + 3 node-count bytes + 1 surface depth float).
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/shadows/light_space_map.h"

namespace penumbra {

class DeepShadowMap final : public LightSpaceMap {
public:
  using ShadowTechnique::transmittance;  // keep the one-point overload visible
  explicit DeepShadowMap(const ShadowSettings& s) : LightSpaceMap(s), nodes_(s.nodes) {}
  void transmittance(std::span<const Vec3> points, std::span<Rgb> out) const override;
  std::size_t memory_bytes() const override { return node_depth_.size() * 2 * sizeof(float) + node_count_.size() + surface_depth_.size() * sizeof(float); }
  std::string_view name() const override { return "deep_shadow_map"; }

  // One channel's transmittance function of a texel at light depth z (unbiased), for tests.
  float evaluate(int ix, int iy, int channel, float z) const;

private:
  void build_map(const ShadowMedium& medium) override;
  std::size_t slot(std::size_t texel, int channel) const { return (texel * 3 + channel) * nodes_; }
  int nodes_;
  std::vector<float> node_depth_, node_value_;  // [texel][channel][node]
  std::vector<std::uint8_t> node_count_;        // [texel][channel]
  std::vector<float> surface_depth_;            // [texel]: first opaque plane, or infinity
};

}  // namespace penumbra
