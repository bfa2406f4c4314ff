#include "penumbra/shadows/deep_shadow_map.h"

#include <tbb/enumerable_thread_specific.h>

#include <algorithm>
#include <cmath>

namespace penumbra {
namespace {

constexpr float kCompressionTolerance = 1e-4f;

// Greedy insertion (see header): indices into (z, T) of at most `budget` vertices.
void compress(const std::vector<float>& z, const std::vector<float>& T, int budget, std::vector<int>& chosen) {
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
      const int a = chosen[s], b = chosen[s + 1];
      const float za = z[static_cast<std::size_t>(a)], zb = z[static_cast<std::size_t>(b)];
      const float ta = T[static_cast<std::size_t>(a)], tb = T[static_cast<std::size_t>(b)];
      for (int i = a + 1; i < b; ++i) {
        const float w = zb > za ? (z[static_cast<std::size_t>(i)] - za) / (zb - za) : 0;
        const float err = std::abs(T[static_cast<std::size_t>(i)] - (ta + (tb - ta) * w));
        if (err > worst) {
          worst = err;
          worst_i = i;
          insert_at = s + 1;
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

}  // namespace

void DeepShadowMap::build_map(const ShadowMedium& medium) {
  const std::size_t texels = static_cast<std::size_t>(resolution_) * resolution_;
  node_depth_.assign(texels * 3 * nodes_, 0.0f);
  node_value_.assign(texels * 3 * nodes_, 1.0f);
  node_count_.assign(texels * 3, 0);
  surface_depth_.assign(texels, kInfinity);
  const float step = medium.step();
  tbb::enumerable_thread_specific<Scratch> scratch;
  for_each_texel([&](int ix, int iy, const Ray& ray) {
    Scratch& s = scratch.local();
    s.z.clear();
    for (auto& t : s.T) t.clear();
    const float surface = medium.surface_hit(ray, 0, kInfinity);
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
    for (int c = 0; c < 3; ++c) {
      if (s.z.empty() || s.T[c].back() >= 1.0f) continue;  // this channel is never absorbed
      compress(s.z, s.T[c], nodes_, s.chosen);
      const std::size_t base = slot(texel, c);
      for (std::size_t j = 0; j < s.chosen.size(); ++j) {
        node_depth_[base + j] = s.z[static_cast<std::size_t>(s.chosen[j])];
        node_value_[base + j] = s.T[c][static_cast<std::size_t>(s.chosen[j])];
      }
      node_count_[texel * 3 + c] = static_cast<std::uint8_t>(s.chosen.size());
    }
  });
}

float DeepShadowMap::evaluate(int ix, int iy, int channel, float z) const {
  const std::size_t texel = texel_index(ix, iy);
  const int n = node_count_[texel * 3 + channel];
  const std::size_t base = slot(texel, channel);
  if (n == 0 || z < node_depth_[base]) return 1.0f;
  for (int j = 1; j < n; ++j) {
    const float z1 = node_depth_[base + j];
    if (z < z1) {
      const float z0 = node_depth_[base + j - 1];
      const float w = z1 > z0 ? (z - z0) / (z1 - z0) : 1.0f;
      return node_value_[base + j - 1] + (node_value_[base + j] - node_value_[base + j - 1]) * w;
    }
  }
  return node_value_[base + n - 1];
}

void DeepShadowMap::transmittance(std::span<const Vec3> points, std::span<Rgb> out) const {
  query(points, out, [&](int ix, int iy, float depth) {
    return depth > surface_depth_[texel_index(ix, iy)]
               ? Rgb(0.0f)
               : Rgb(evaluate(ix, iy, 0, depth), evaluate(ix, iy, 1, depth), evaluate(ix, iy, 2, depth));
  });
}

}  // namespace penumbra
