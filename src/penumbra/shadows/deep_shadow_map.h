// Deep shadow map for volumes (Lokovic & Veach 2000; Hadwiger et al. 2006; the CSSM paper's baseline,
// Weidner & Linsen, "3 nodes per color channel", §4): per texel a piecewise-linear transmittance function
// T(z) of at most N nodes; T = 1 before the first node, constant after the last. Two layouts
// (`shadows.dsm_layout`):
//
//  - per_channel (default): every colour channel has its own N nodes (z_j, T_j), compressed on its own;
//    6 floats a node for the three channels.
//  - shared_depth: the layout of the paper's GPU deep shadow map ("four values for each node", §4):
//    N node depths z_j shared by the three channels, an RGB transmittance (T_r, T_g, T_b)_j per node;
//    4 floats a node.
//
// Compression rule (the papers leave it open; docs/techniques/deep_shadow_map.md): the exact function
// along the texel's ray is a polyline with a vertex at each absorbing segment's end (and where an
// absorbing run begins). Start from its first and last vertices and repeatedly insert the vertex
// farthest from the current piecewise-linear approximation, until N nodes are used or the error is
// below 1e-4 (greedy Douglas–Peucker insertion). It keeps both ends exact and places interior nodes
// where T bends most. "Farthest" is |ΔT| of the one channel for per_channel; for shared_depth it is the
// largest |ΔT_λ| over the three channels (L∞), so a shared node goes where any channel bends most and
// the compression is exact once N covers the polyline's vertices, as for per_channel.
//
// | parameter           | default         | meaning                                               |
// | shadows.resolution  | 1024            | texels per side                                       |
// | shadows.nodes       | 3               | N: nodes per colour channel (per_channel) or per texel (shared_depth) |
// | shadows.dsm_layout  | per_channel     | per_channel or shared_depth (the paper's)             |
// | shadows.bias        | one shadow step | world units                                           |
// Across bricks (accel/brick_reduction.h; a distributed frame): each brick marches the segments it
// owns. The transmittance through the bricks in front of it (an exclusive product over the bricks, in
// the order each ray crosses them) continues its part of every texel's polyline, so the bricks' parts
// are the whole polyline, cut at the brick faces. The compression then runs over the bricks: the
// first and last vertices are the nearest and farthest over them, and each further node is the vertex
// farthest from the nodes so far over all bricks (the earliest where several are), found by minima of
// −error, then depth, then its transmittance from the brick holding it — the whole map's greedy
// insertion, one round of three reductions a node, each brick marching its part again. It differs from
// the whole map only by rounding: the bricks' products multiply in another order, and a brick face adds
// a vertex where an absorbing run crosses it (the same point as its neighbour's last).
// Opaque planes are not folded into the function (with few nodes, the vertical drop to zero would
// pull the interpolated T down well before the surface); each texel keeps the depth of its first
// opaque surface, as a classic shadow map does, and T = 0 beyond it.
// Memory, resolution² times: per_channel 3·N·(depth, T) floats + 3 node-count bytes + 1 surface depth
// float (79 B at N = 3); shared_depth N·(depth, T_r, T_g, T_b) floats + 1 count byte + 1 surface depth
// float (53 B at N = 3; the paper counts the 12 node values, 48 B).
#pragma once

#include <cstdint>
#include <vector>

#include "penumbra/lighting/technique_info.h"
#include "penumbra/shadows/light_space_map.h"

namespace penumbra {

const TechniqueInfo& deep_shadow_map_technique();

enum class DsmLayout { PerChannel, SharedDepth };

// "per_channel" / "shared_depth"; throws Error for anything else.
DsmLayout parse_dsm_layout(const std::string& name);

class DeepShadowMap final : public LightSpaceMap {
public:
  using ShadowTechnique::transmittance;  // keep the one-point overload visible
  explicit DeepShadowMap(const TechniqueParams& params);
  void transmittance(std::span<const Vec3> points, std::span<Rgb> out) const override;
  std::size_t memory_bytes() const override {
    return (node_depth_.size() + node_value_.size()) * sizeof(float) + node_count_.size() + surface_depth_.size() * sizeof(float);
  }
  std::string_view name() const override { return "deep_shadow_map"; }
  DsmLayout layout() const { return layout_; }

  // One channel's transmittance function of a texel at light depth z (unbiased), for tests.
  float evaluate(int ix, int iy, int channel, float z) const;
  // Nodes a texel's channel uses, and the depth of its j-th node (shared_depth: the same for every channel).
  int node_count(int ix, int iy, int channel) const;
  float node_depth(int ix, int iy, int channel, int j) const;

  bool combines_over_bricks() const override { return true; }

private:
  void build_map(const ShadowCasters& medium) override;
  void build_brick(const ShadowCasters& medium, const ShadowBrick& brick);
  Rgb evaluate_shared(std::size_t texel, float z) const;
  // per_channel: [texel][channel][node]; shared_depth: depths [texel][node], values [texel][node][channel]
  std::size_t slot(std::size_t texel, int channel) const {
    return layout_ == DsmLayout::PerChannel ? (texel * 3 + channel) * nodes_ : texel * nodes_;
  }
  std::size_t count_index(std::size_t texel, int channel) const {
    return layout_ == DsmLayout::PerChannel ? texel * 3 + channel : texel;
  }
  int nodes_;
  DsmLayout layout_;
  std::vector<float> node_depth_, node_value_;
  std::vector<std::uint8_t> node_count_;        // [texel][channel] or [texel]
  std::vector<float> surface_depth_;            // [texel]: first opaque plane, or infinity
};

}  // namespace penumbra
