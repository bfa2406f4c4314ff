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

// The exact polyline along `ray` (see the header): vertex(z, T) at each absorbing segment's end, and
// where an absorbing run begins; T continues from `T` (1, or the bricks' in front) and is left as it
// ends. Stops once every channel is opaque.
template <class Vertex>
void march_polyline(const ShadowCasters& medium, const Ray& ray, float surface, Rgb& T, Vertex&& vertex) {
  const float step = medium.step();
  float last_end = -kInfinity;
  medium.march(ray, 0, surface, [&](const MediumSegment& seg) {
    // T before the segment at its start (unless it continues the previous one), T after it at its end
    if (seg.t_begin > last_end + 1e-6f * step) vertex(seg.t_begin, T);
    T *= Rgb(1.0f) - (Rgb(1.0f) - seg.transmission) * seg.alpha;
    vertex(seg.t_end, T);
    last_end = seg.t_end;
    return T.max_component() > kShadowOpaque;
  });
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

namespace {
const ParamSpec kNodes = integer_param("nodes", 3, 2, 64, "", "N: nodes per colour channel (per_channel) or per texel (shared_depth)");
const ParamSpec kLayout = choice_param("dsm_layout", "per_channel", {"per_channel", "shared_depth"},
                                       "one polyline per channel, or node depths shared by R, G, B (the CSSM paper's DSM)");
}  // namespace

const TechniqueInfo& deep_shadow_map_technique() {
  static const TechniqueInfo info{"deep_shadow_map", TechniqueFamily::Shadow, kAllKinds,
                                  "deep shadow map: the transmittance along each texel's ray as a compressed polyline (Lokovic & Veach)",
                                  {kMapResolution, kMapBias, kLightStep, kNodes, kLayout},
                                  {.sphere_rays = true},
                                  shadow_factory<DeepShadowMap>(),
                                  {}};
  return info;
}

DeepShadowMap::DeepShadowMap(const TechniqueParams& params)
    : LightSpaceMap(params), nodes_(static_cast<int>(kNodes.integer(params))), layout_(parse_dsm_layout(kLayout.choice(params))) {}

void DeepShadowMap::build_map(const ShadowCasters& medium) {
  const std::size_t texels = static_cast<std::size_t>(resolution_) * resolution_;
  const bool shared = layout_ == DsmLayout::SharedDepth;
  const std::size_t depths = texels * nodes_ * (shared ? 1 : 3);
  node_depth_.assign(depths, 0.0f);
  node_value_.assign(texels * 3 * nodes_, 1.0f);
  node_count_.assign(shared ? texels : texels * 3, 0);
  surface_depth_.assign(texels, kInfinity);
  const ShadowBrick* brick = medium.brick();
  if (brick && !brick->slab.whole()) return build_brick(medium, *brick);  // one brick of the whole volume: the map itself
  tbb::enumerable_thread_specific<Scratch> scratch;
  for_each_texel([&](int ix, int iy, const Ray& ray) {
    Scratch& s = scratch.local();
    s.z.clear();
    for (auto& t : s.T) t.clear();
    const float surface = first_surface(medium, ray);
    Rgb T(1.0f);
    march_polyline(medium, ray, surface, T, [&](float z, const Rgb& v) {
      s.z.push_back(z);
      for (int c = 0; c < 3; ++c) s.T[c].push_back(v[c]);
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

// The same compression spread over the bricks (the header's "Across bricks"): every round marches this
// brick's part of each texel's polyline again and the bricks agree, through minima, on the vertex to
// insert — the ends first, then the farthest from the nodes so far (the earliest where several are),
// its depth and its transmittance from the brick that holds it.
void DeepShadowMap::build_brick(const ShadowCasters& medium, const ShadowBrick& brick) {
  const std::size_t texels = surface_depth_.size();
  const bool shared = layout_ == DsmLayout::SharedDepth;
  const int curves = shared ? 1 : 3, channels = shared ? 3 : 1;  // curves per texel, channels per curve
  const std::size_t n_curves = texels * static_cast<std::size_t>(curves);
  BrickReduction& reduction = *brick.reduction;
  // 1. each texel's transmittance through this brick alone, then through the bricks in front of it
  std::vector<float> through[2] = {std::vector<float>(texels * 3, 1.0f), std::vector<float>(texels * 3, 1.0f)};
  std::vector<std::uint8_t> upwards(texels, 0);
  for_each_texel([&](int ix, int iy, const Ray& ray) {
    const std::size_t texel = texel_index(ix, iy);
    surface_depth_[texel] = first_surface(medium, ray);
    upwards[texel] = ray.direction.z >= 0 ? 1 : 0;
    Rgb T(1.0f);
    march_polyline(medium, ray, surface_depth_[texel], T, [](float, const Rgb&) {});
    for (int c = 0; c < 3; ++c) through[upwards[texel]][texel * 3 + static_cast<std::size_t>(c)] = T[c];
  });
  reduction.exclusive_product(through[1], true);
  reduction.exclusive_product(through[0], false);
  const auto in_front = [&](std::size_t texel) {
    const float* f = &through[upwards[texel]][texel * 3];
    return Rgb(f[0], f[1], f[2]);
  };
  // This brick's part of a texel's polyline, continued from the bricks in front (none once they are opaque).
  const auto polyline = [&](std::size_t texel, const Ray& ray, auto&& vertex) {
    Rgb T = in_front(texel);
    if (T.max_component() > kShadowOpaque) march_polyline(medium, ray, surface_depth_[texel], T, vertex);
  };

  // 2. the polyline's first and last vertices: the nearest first and farthest last over the bricks
  std::vector<float> ends(texels * 2, kInfinity);  // [first depth] [−last depth]
  std::vector<Rgb> first_T(texels), last_T(texels);
  for_each_texel([&](int ix, int iy, const Ray& ray) {
    const std::size_t texel = texel_index(ix, iy);
    polyline(texel, ray, [&](float z, const Rgb& T) {
      if (ends[texel] == kInfinity) ends[texel] = z, first_T[texel] = T;
      ends[texels + texel] = -z;
      last_T[texel] = T;
    });
  });
  const std::vector<float> own_ends = ends;
  reduction.minimum(ends);
  std::vector<float> end_values(texels * 6, kInfinity);  // [texel][first RGB, last RGB] from the brick holding each
  for (std::size_t t = 0; t < texels; ++t)
    for (int c = 0; c < 3; ++c) {
      if (own_ends[t] == ends[t] && ends[t] < kInfinity) end_values[t * 6 + static_cast<std::size_t>(c)] = first_T[t][c];
      if (own_ends[texels + t] == ends[texels + t] && ends[t] < kInfinity) end_values[t * 6 + 3 + static_cast<std::size_t>(c)] = last_T[t][c];
    }
  reduction.minimum(end_values);
  const auto value_slot = [&](std::size_t texel, int curve, int j, int c) {  // channel c of curve `curve`'s node j
    return shared ? (slot(texel, 0) + static_cast<std::size_t>(j)) * 3 + static_cast<std::size_t>(c)
                  : slot(texel, curve) + static_cast<std::size_t>(j);
  };
  for (std::size_t t = 0; t < texels; ++t) {
    if (ends[t] == kInfinity) continue;  // nothing absorbed along this texel's ray
    for (int k = 0; k < curves; ++k) {
      bool absorbed = false;
      for (int c = 0; c < channels; ++c) absorbed = absorbed || end_values[t * 6 + 3 + static_cast<std::size_t>(k * channels + c)] < 1.0f;
      if (!absorbed) continue;
      const std::size_t base = slot(t, k);
      const float depth[2] = {ends[t], -ends[texels + t]};
      const int count = depth[1] > depth[0] && nodes_ > 1 ? 2 : 1;
      for (int j = 0; j < count; ++j) {
        node_depth_[base + static_cast<std::size_t>(j)] = depth[j];
        for (int c = 0; c < channels; ++c)
          node_value_[value_slot(t, k, j, c)] = end_values[t * 6 + static_cast<std::size_t>(3 * j + k * channels + c)];
      }
      node_count_[count_index(t, k)] = static_cast<std::uint8_t>(count);
    }
  }

  // 3. the interior nodes, one a round: the vertex farthest from the piecewise-linear nodes so far
  std::vector<float> worst(n_curves), where(n_curves), values(n_curves * static_cast<std::size_t>(channels));
  std::vector<float> own_worst(n_curves), own_where(n_curves), own_values(values.size());
  for (int round = 2; round < nodes_; ++round) {
    std::fill(own_worst.begin(), own_worst.end(), kInfinity);  // −error, +∞ where no vertex is above the tolerance
    for_each_texel([&](int ix, int iy, const Ray& ray) {
      const std::size_t texel = texel_index(ix, iy);
      float best[3] = {kCompressionTolerance, kCompressionTolerance, kCompressionTolerance};
      polyline(texel, ray, [&](float z, const Rgb& T) {
        for (int k = 0; k < curves; ++k) {
          const std::size_t curve = texel * static_cast<std::size_t>(curves) + static_cast<std::size_t>(k);
          const int n = node_count_[count_index(texel, k)];
          const float* depth = &node_depth_[slot(texel, k)];
          int j = 0;
          while (j + 1 < n && depth[j + 1] < z) ++j;
          if (n < 2 || z < depth[0] || z > depth[n - 1]) continue;
          const float za = depth[j], zb = depth[j + 1];
          const float w = zb > za ? (z - za) / (zb - za) : 0;
          float err = 0;
          for (int c = 0; c < channels; ++c) {
            const float a = node_value_[value_slot(texel, k, j, c)], b = node_value_[value_slot(texel, k, j + 1, c)];
            err = std::max(err, std::abs(T[k * channels + c] - (a + (b - a) * w)));
          }
          if (err > best[k]) {
            best[k] = err;
            own_worst[curve] = -err;
            own_where[curve] = z;
            for (int c = 0; c < channels; ++c) own_values[curve * static_cast<std::size_t>(channels) + static_cast<std::size_t>(c)] = T[k * channels + c];
          }
        }
      });
    });
    worst = own_worst;
    reduction.minimum(worst);
    for (std::size_t i = 0; i < n_curves; ++i) where[i] = own_worst[i] == worst[i] && worst[i] < kInfinity ? own_where[i] : kInfinity;
    reduction.minimum(where);
    for (std::size_t i = 0; i < n_curves; ++i)
      for (int c = 0; c < channels; ++c) {
        const std::size_t v = i * static_cast<std::size_t>(channels) + static_cast<std::size_t>(c);
        values[v] = own_worst[i] == worst[i] && own_where[i] == where[i] && where[i] < kInfinity ? own_values[v] : kInfinity;
      }
    reduction.minimum(values);
    for (std::size_t i = 0; i < n_curves; ++i) {
      if (where[i] == kInfinity) continue;
      const std::size_t texel = i / static_cast<std::size_t>(curves);
      const int k = static_cast<int>(i % static_cast<std::size_t>(curves));
      const int n = node_count_[count_index(texel, k)];
      float* depth = &node_depth_[slot(texel, k)];
      int at = n;
      while (at > 0 && depth[at - 1] > where[i]) --at;
      for (int j = n; j > at; --j) {
        depth[j] = depth[j - 1];
        for (int c = 0; c < channels; ++c) node_value_[value_slot(texel, k, j, c)] = node_value_[value_slot(texel, k, j - 1, c)];
      }
      depth[at] = where[i];
      for (int c = 0; c < channels; ++c) node_value_[value_slot(texel, k, at, c)] = values[i * static_cast<std::size_t>(channels) + static_cast<std::size_t>(c)];
      node_count_[count_index(texel, k)] = static_cast<std::uint8_t>(n + 1);
    }
  }
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
