#include "penumbra/shadows/deep_shadow_map.h"

#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <cmath>

#include "penumbra/core/error.h"

namespace penumbra {
namespace {

constexpr float kCompressionTolerance = 1e-4f;

// Greedy insertion (see header): indices into (z, T) of at most `budget` vertices. `channels` are the
// transmittance arrays whose largest deviation decides (one for per_channel, three for shared_depth).
void compress(const std::vector<float>& z, std::span<const std::vector<float>* const> channels, int budget,
              std::vector<int>& chosen) {
  chosen.clear();
  const int n = static_cast<int>(z.size());
  if (n == 0) return;
  chosen.push_back(0);
  if (n > 1) chosen.push_back(n - 1);
  while (static_cast<int>(chosen.size()) < budget) {
    float worst = kCompressionTolerance;
    int worst_i = -1;
    std::size_t insert_at = 0;
    for (std::size_t s = 0; s + 1 < chosen.size(); ++s) {
      const auto a = static_cast<std::size_t>(chosen[s]), b = static_cast<std::size_t>(chosen[s + 1]);
      const float za = z[a], zb = z[b];
      for (std::size_t i = a + 1; i < b; ++i) {
        const float w = zb > za ? (z[i] - za) / (zb - za) : 0;
        for (const std::vector<float>* T : channels) {
          const float err = std::abs((*T)[i] - ((*T)[a] + ((*T)[b] - (*T)[a]) * w));
          if (err > worst) {
            worst = err;
            worst_i = static_cast<int>(i);
            insert_at = s + 1;
          }
        }
      }
    }
    if (worst_i < 0) break;
    chosen.insert(chosen.begin() + static_cast<std::ptrdiff_t>(insert_at), worst_i);
  }
}

struct Scratch {
  std::vector<float> z;
  std::vector<float> T[3];
  std::vector<int> chosen;
};

// Piecewise-linear interpolation of nodes (depth[j], value[j·stride]) at z; 1 before the first node.
float interpolate(const float* depth, const float* value, int stride, int n, float z) {
  if (n == 0 || z < depth[0]) return 1.0f;
  for (int j = 1; j < n; ++j)
    if (z < depth[j]) {
      const float z0 = depth[j - 1], z1 = depth[j];
      const float w = z1 > z0 ? (z - z0) / (z1 - z0) : 1.0f;
      const float v0 = value[(j - 1) * stride], v1 = value[j * stride];
      return v0 + (v1 - v0) * w;
    }
  return value[(n - 1) * stride];
}

}  // namespace

DsmLayout parse_dsm_layout(const std::string& name) {
  if (name == "per_channel") return DsmLayout::PerChannel;
  if (name == "shared_depth") return DsmLayout::SharedDepth;
  throw Error("shadows.dsm_layout: unknown value '" + name + "' (expected per_channel or shared_depth)");
}

DeepShadowMap::DeepShadowMap(const ShadowSettings& s)
    : LightSpaceMap(s), nodes_(s.nodes), layout_(parse_dsm_layout(s.dsm_layout)) {}

void DeepShadowMap::build_map(const ShadowCasters& medium) {
  const std::size_t texels = static_cast<std::size_t>(resolution_) * resolution_;
  const bool shared = layout_ == DsmLayout::SharedDepth;
  const std::size_t depths = texels * nodes_ * (shared ? 1 : 3);
  node_depth_.assign(depths, 0.0f);
  node_value_.assign(texels * 3 * nodes_, 1.0f);
  node_count_.assign(shared ? texels : texels * 3, 0);
  surface_depth_.assign(texels, kInfinity);
  const float step = medium.step();
  tbb::enumerable_thread_specific<Scratch> scratch;
  for_each_texel([&](int ix, int iy, const Ray& ray) {
    Scratch& s = scratch.local();
    s.z.clear();
    for (auto& t : s.T) t.clear();
    const float surface = first_surface(medium, ray);
    Rgb T(1.0f);
    float last_end = -kInfinity;
    medium.march(ray, 0, surface, [&](const MediumSegment& seg) {
      // the polyline: T before the segment at its start (unless it continues the previous one), T after it at its end
      const float start = seg.t_begin, end = seg.t_end;
      if (start > last_end + 1e-6f * step) {
        s.z.push_back(start);
        for (int c = 0; c < 3; ++c) s.T[c].push_back(T[c]);
      }
      T *= Rgb(1.0f) - (Rgb(1.0f) - seg.transmission) * seg.alpha;
      s.z.push_back(end);
      for (int c = 0; c < 3; ++c) s.T[c].push_back(T[c]);
      last_end = end;
      return T.max_component() > kShadowOpaque;
    });
    const std::size_t texel = texel_index(ix, iy);
    surface_depth_[texel] = surface;
    if (s.z.empty()) return;
    if (shared) {
      if (s.T[0].back() >= 1.0f && s.T[1].back() >= 1.0f && s.T[2].back() >= 1.0f) return;  // nothing absorbed
      const std::vector<float>* all[3] = {&s.T[0], &s.T[1], &s.T[2]};
      compress(s.z, all, nodes_, s.chosen);
      const std::size_t base = slot(texel, 0);
      for (std::size_t j = 0; j < s.chosen.size(); ++j) {
        const auto v = static_cast<std::size_t>(s.chosen[j]);
        node_depth_[base + j] = s.z[v];
        for (int c = 0; c < 3; ++c) node_value_[(base + j) * 3 + c] = s.T[c][v];
      }
      node_count_[texel] = static_cast<std::uint8_t>(s.chosen.size());
      return;
    }
    for (int c = 0; c < 3; ++c) {
      if (s.T[c].back() >= 1.0f) continue;  // this channel is never absorbed
      const std::vector<float>* one[1] = {&s.T[c]};
      compress(s.z, one, nodes_, s.chosen);
      const std::size_t base = slot(texel, c);
      for (std::size_t j = 0; j < s.chosen.size(); ++j) {
        node_depth_[base + j] = s.z[static_cast<std::size_t>(s.chosen[j])];
        node_value_[base + j] = s.T[c][static_cast<std::size_t>(s.chosen[j])];
      }
      node_count_[texel * 3 + c] = static_cast<std::uint8_t>(s.chosen.size());
    }
  });
}

int DeepShadowMap::node_count(int ix, int iy, int channel) const { return node_count_[count_index(texel_index(ix, iy), channel)]; }

float DeepShadowMap::node_depth(int ix, int iy, int channel, int j) const {
  return node_depth_[slot(texel_index(ix, iy), channel) + static_cast<std::size_t>(j)];
}

float DeepShadowMap::evaluate(int ix, int iy, int channel, float z) const {
  const std::size_t texel = texel_index(ix, iy);
  const std::size_t base = slot(texel, channel);
  const int n = node_count_[count_index(texel, channel)];
  if (layout_ == DsmLayout::SharedDepth) return interpolate(&node_depth_[base], &node_value_[base * 3 + channel], 3, n, z);
  return interpolate(&node_depth_[base], &node_value_[base], 1, n, z);
}

Rgb DeepShadowMap::evaluate_shared(std::size_t texel, float z) const {
  // one node search for the three channels
  const std::size_t base = texel * nodes_;
  const int n = node_count_[texel];
  const float* depth = &node_depth_[base];
  const float* value = &node_value_[base * 3];
  if (n == 0 || z < depth[0]) return Rgb(1.0f);
  for (int j = 1; j < n; ++j)
    if (z < depth[j]) {
      const float z0 = depth[j - 1], z1 = depth[j];
      const float w = z1 > z0 ? (z - z0) / (z1 - z0) : 1.0f;
      const float* v0 = value + (j - 1) * 3;
      const float* v1 = value + j * 3;
      return Rgb(v0[0] + (v1[0] - v0[0]) * w, v0[1] + (v1[1] - v0[1]) * w, v0[2] + (v1[2] - v0[2]) * w);
    }
  const float* v = value + (n - 1) * 3;
  return Rgb(v[0], v[1], v[2]);
}

void DeepShadowMap::transmittance(std::span<const Vec3> points, std::span<Rgb> out) const {
  if (layout_ == DsmLayout::SharedDepth) {
    query(points, out, [&](int ix, int iy, float depth) {
      const std::size_t texel = texel_index(ix, iy);
      return depth > surface_depth_[texel] ? Rgb(0.0f) : evaluate_shared(texel, depth);
    });
    return;
  }
  query(points, out, [&](int ix, int iy, float depth) {
    return depth > surface_depth_[texel_index(ix, iy)]
               ? Rgb(0.0f)
               : Rgb(evaluate(ix, iy, 0, depth), evaluate(ix, iy, 1, depth), evaluate(ix, iy, 2, depth));
  });
}

}  // namespace penumbra
