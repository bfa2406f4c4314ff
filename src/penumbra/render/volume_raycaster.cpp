#include "penumbra/render/volume_raycaster.h"

#include <array>
#include <atomic>
#include <cmath>
#include <vector>

#include "penumbra/core/cancel.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/rng.h"
#include "penumbra/render/surface_shading.h"

namespace penumbra {
namespace {

constexpr int kTileSize = 16;
constexpr std::size_t kSampleBatch = 32;  // samples whose shadow queries are issued together

// Samples of one ray waiting for their lights' transmittance; their compositing weights are already
// known (opacity does not depend on light), so shading them later gives the same sum.
struct SampleBatch {
  std::array<Vec3, kSampleBatch> position;
  std::array<Vec3, kSampleBatch> normal;    // unit, facing the viewer
  std::array<float, kSampleBatch> shaded;   // 0..1: how much of Blinn–Phong applies (gradient strength)
  std::array<Rgb, kSampleBatch> color;      // transfer-function colour
  std::array<float, kSampleBatch> weight;   // (1 − A)·α
  std::array<bool, kSampleBatch> receives;  // the sample's volume receives shadows
  std::size_t size = 0;
};

struct Shader {
  const RayCastInputs& in;
  const ShadingParams& k;
  Vec3 view;  // towards the eye
  float kSpecularCutoff;  // highlight_cutoff(): cos below which (cos)^shininess < 1e-4, or none

  // Adds the shaded batch to `accum` and empties it.
  void flush(SampleBatch& b, Rgb& accum) const {
    if (b.size == 0) return;
    const std::span<const Vec3> points(b.position.data(), b.size);
    std::array<Rgb, kSampleBatch> lit;
    std::array<Rgb, kSampleBatch> T;
    // one fetch per sample for every term the light cache holds; a sample next to a cell it left
    // unfilled asks the techniques themselves
    const LightCache* cache = in.light_cache;
    std::array<std::array<float, LightCache::kMaxChannels>, kSampleBatch> cached;
    std::array<bool, kSampleBatch> fetched{};
    if (cache)
      for (std::size_t i = 0; i < b.size; ++i) fetched[i] = cache->try_fetch(b.position[i], cached[i].data());
    if (in.ambient) {
      if (cache && cache->has_ambient()) {
        for (std::size_t i = 0; i < b.size; ++i)
          T[i] = fetched[i] ? Rgb(cached[i][0], cached[i][1], cached[i][2]) : in.ambient->ambient(b.position[i]);
      } else {
        in.ambient->ambient(points, std::span<Rgb>(T.data(), b.size));
      }
      for (std::size_t i = 0; i < b.size; ++i) lit[i] = b.color[i] * T[i] * k.ambient;
    } else {
      for (std::size_t i = 0; i < b.size; ++i) lit[i] = b.color[i] * k.ambient;
    }
    for (std::size_t l = 0; l < in.lights.size(); ++l) {
      const int slot = cache && l < in.cached_light_slot.size() ? in.cached_light_slot[l] : -1;
      if (slot >= 0) {
        const auto channel = static_cast<std::size_t>(cache->light_channel(static_cast<std::size_t>(slot)));
        for (std::size_t i = 0; i < b.size; ++i)
          T[i] = fetched[i] ? Rgb(cached[i][channel]) : in.shadows[l]->transmittance(b.position[i]);
      } else {
        in.shadows[l]->transmittance(points, std::span<Rgb>(T.data(), b.size));
      }
      const Light& light = in.lights[l];
      // a directional light's direction, emission and half vector are the same for every sample
      const bool directional = light.type == LightType::Directional;
      Vec3 to_light, half;
      Rgb emitted;
      if (directional) {
        float distance;
        light.towards(Vec3{0, 0, 0}, to_light, distance);
        emitted = light.emitted(to_light);
        half = normalize(to_light + view);
      }
      for (std::size_t i = 0; i < b.size; ++i) {
        if (!directional) {
          float distance;
          light.towards(b.position[i], to_light, distance);
          emitted = light.emitted(to_light);
        }
        const Rgb e = emitted * (b.receives[i] ? T[i] : Rgb(1.0f));
        const float ndotl = dot(b.normal[i], to_light);
        const float diffuse = (1 - b.shaded[i]) + b.shaded[i] * std::max(ndotl, 0.0f);
        float spec = 0;
        if (ndotl > 0 && b.shaded[i] > 0) {
          const float ndoth = dot(b.normal[i], directional ? half : normalize(to_light + view));
          // below this cosine the highlight is under 1e-4 for shininess >= 8: skip the pow
          if (ndoth > kSpecularCutoff) spec = b.shaded[i] * std::pow(ndoth, k.shininess);
        }
        lit[i] += e * (b.color[i] * (k.diffuse * diffuse) + Rgb(k.specular * spec));
      }
    }
    for (std::size_t i = 0; i < b.size; ++i) accum += lit[i] * b.weight[i];
    b.size = 0;
  }

  // Queues a classified sample of `pv` at p (in `cell` of its volume) with compositing weight w.
  void add(SampleBatch& batch, Rgb& color, const PreparedVolume& pv, const Vec3& p, const TrilinearCell& cell, const Rgb& rgb,
           float w) const {
    Vec3 g;
    float shaded;
    pv.normal_at(cell, g, shaded);
    const float g_len = length(g);
    const std::size_t i = batch.size++;
    batch.position[i] = p;
    batch.normal[i] = g_len > 0 ? (dot(g, view) >= 0 ? g / g_len : -g / g_len) : view;
    batch.shaded[i] = g_len > 0 ? shaded : 0.0f;
    batch.color[i] = rgb;
    batch.weight[i] = w;
    batch.receives[i] = pv.object->receives_shadows;
    if (batch.size == kSampleBatch) flush(batch, color);
  }
};

// A tile's tally of lattice samples (VolumeFrame::samples, shaded_samples), added to the frame's once.
struct SampleCounts {
  std::size_t classified = 0, shaded = 0;
};

// One volume: the lattice walk with macrocell skipping, for voxels of type T (the volume's), of every
// sample or (kSlab) of the samples in.owned holds — two instances, so that the whole frame's walk
// carries no ownership test.
// `half` becomes the ray parameter where the opacity first reaches 1/2 (left as it is when it never does).
template <class T, bool kSlab>
float trace_one(const PreparedVolume& pv, const Shader& shader, const Ray& ray, float jitter, float t_start, float t_surface,
                SampleBatch& batch, Rgb& color, float& half, SampleCounts& counts) {
  float opacity = 0;
  float t0, t1;
  if (!pv.span(ray, t0, t1, t_start, t_surface)) return opacity;
  const SampleSlab* owned = shader.in.owned;
  if constexpr (kSlab) {
    if (!owned->clip(ray, pv.step, t0, t1)) return opacity;
  }
  const Volume& vol = *pv.volume;
  const float dt = pv.step;
  const EmptySpaceSkipper skipper(vol, pv.grid, pv.empty);
  std::size_t last_cell = SIZE_MAX;
  // sample k sits at t = (k + jitter)·Δ; integer indices, so t advances however far the volume is
  for (auto k = static_cast<std::int64_t>(std::ceil(t0 / dt - jitter));; ++k) {
    const float t = (static_cast<float>(k) + jitter) * dt;
    if (t > t1) break;
    const Vec3 p = ray.at(t);
    if constexpr (kSlab) {
      if (!owned->owns(p)) continue;  // another brick's sample
    }
    const Vec3 v = vol.to_voxel(p);
    const TrilinearCell tc = vol.trilinear_cell(v);  // shared by the macrocell, the value and the gradient
    const std::size_t cell = skipper.cell_of(tc);
    if (cell != last_cell) {
      last_cell = cell;
      if (skipper.empty(cell)) {  // continue with the first lattice sample past the cell
        const float exit = skipper.cell_exit(ray, t, v);
        k = std::max(k, static_cast<std::int64_t>(std::ceil(exit / dt - jitter)) - 1);
        last_cell = SIZE_MAX;
        continue;
      }
    }
    const Rgba s = pv.lut.lookup(vol.sample_cell_as<T>(tc));
    ++counts.classified;
    if (s.a <= 0) continue;
    const float w = (1 - opacity) * s.a;
    opacity += w;
    if (opacity >= 0.5f && half == kInfinity) half = t;
    ++counts.shaded;
    shader.add(batch, color, pv, p, tc, s.rgb, w);
    if (opacity >= kEarlyTermination) break;
  }
  shader.flush(batch, color);
  return opacity;
}

// The samples of one lattice position that several volumes classify: room for every volume (any number
// may overlap), allocated once per tile.
struct OverlapSamples {
  explicit OverlapSamples(std::size_t volumes) : sample(volumes), cells(volumes), holder(volumes) {}
  std::vector<Rgba> sample;
  std::vector<TrilinearCell> cells;
  std::vector<const PreparedVolume*> holder;
};

// Several volumes on one lattice: every volume that holds a sample classifies it; space is skipped
// only where every volume is empty (or absent).
float trace_many(std::span<const PreparedVolume* const> volumes, const Shader& shader, const Ray& ray, float jitter,
                 float t_start, float t_surface, SampleBatch& batch, OverlapSamples& overlap, Rgb& color, float& half, SampleCounts& counts) {
  float opacity = 0;
  float t0 = kInfinity, t1 = -kInfinity;
  for (const PreparedVolume* pv : volumes) {
    float a, b;
    if (pv->span(ray, a, b, t_start, t_surface)) {
      t0 = std::min(t0, a);
      t1 = std::max(t1, b);
    }
  }
  if (!(t0 <= t1)) return opacity;
  const float dt = volumes.front()->step;  // the renderer gives every volume the same step
  const SampleSlab* owned = shader.in.owned;
  if (owned && !owned->clip(ray, dt, t0, t1)) return opacity;
  auto& [sample, cells, holder] = overlap;
  for (auto k = static_cast<std::int64_t>(std::ceil(t0 / dt - jitter));; ++k) {
    const float t = (static_cast<float>(k) + jitter) * dt;
    if (t > t1) break;
    const Vec3 p = ray.at(t);
    if (owned && !owned->owns(p)) continue;  // another brick's sample
    std::size_t n = 0;
    float skip_to = kInfinity;
    bool occupied = false;
    for (const PreparedVolume* pv : volumes) {
      float a0, a1;
      if (!pv->span(ray, a0, a1, t, t1)) continue;
      if (a0 > t) {
        skip_to = std::min(skip_to, a0);
        continue;
      }
      const Vec3 v = pv->volume->to_voxel(p);
      const EmptySpaceSkipper skipper(*pv->volume, pv->grid, pv->empty);
      const std::size_t cell = skipper.cell_of(v);
      if (skipper.empty(cell)) {
        skip_to = std::min(skip_to, skipper.cell_exit(ray, t, v));
        continue;
      }
      occupied = true;
      const TrilinearCell tc = pv->volume->trilinear_cell(v);
      const Rgba s = pv->lut.lookup(pv->volume->sample_cell(tc));
      ++counts.classified;
      if (s.a <= 0) continue;
      sample[n] = s;
      cells[n] = tc;
      holder[n] = pv;
      ++n;
    }
    if (!occupied) {
      if (skip_to == kInfinity) break;
      k = std::max(k, static_cast<std::int64_t>(std::ceil(skip_to / dt - jitter)) - 1);
      continue;
    }
    if (n == 0) continue;
    float clear = 1, alpha_sum = 0;
    for (std::size_t i = 0; i < n; ++i) {
      clear *= 1 - sample[i].a;
      alpha_sum += sample[i].a;
    }
    const float w = (1 - opacity) * (1 - clear);
    opacity += w;
    if (opacity >= 0.5f && half == kInfinity) half = t;
    counts.shaded += n;
    for (std::size_t i = 0; i < n; ++i) shader.add(batch, color, *holder[i], p, cells[i], sample[i].rgb, w * sample[i].a / alpha_sum);
    if (opacity >= kEarlyTermination) break;
  }
  shader.flush(batch, color);
  return opacity;
}

}  // namespace

VolumeFrame render_volume_frame(const RayCastInputs& in) {
  const Camera& cam = *in.camera;
  const std::size_t pixels = static_cast<std::size_t>(cam.width) * static_cast<std::size_t>(cam.height);
  VolumeFrame out{Image(cam.width, cam.height), std::vector<float>(pixels, 0.0f), std::vector<float>(pixels, kInfinity)};
  Progress progress("render", static_cast<std::size_t>(cam.height));
  bool jittered = false;
  for (const PreparedVolume* pv : in.volumes) jittered = jittered || pv->object->jitter;
  const float specular_cutoff = highlight_cutoff(in.scene->shading);
  const PrimaryRays rays(cam);
  const std::uint64_t jitter_key = 0x6a177e5 + static_cast<std::uint64_t>(in.sample) * 0x9e3779b97f4a7c15ull;
  std::atomic<std::size_t> classified{0}, shaded{0};
  parallel_for_tiles(cam.width, cam.height, kTileSize, [&](const Tile& tile) {
    SampleBatch batch;
    SampleCounts counts;
    OverlapSamples overlap(in.volumes.size() > 1 ? in.volumes.size() : 0);  // one volume: trace_one, no overlap
    for (int y = tile.y0; y < tile.y1; ++y) {
      if (cancel_requested()) return;  // a row can take long (ray-traced shadows): stop between rows
      for (int x = tile.x0; x < tile.x1; ++x) {
        const Ray ray = rays.ray(x, y);
        const Shader shader{in, in.scene->shading, -ray.direction, specular_cutoff};
        const float jitter = jittered ? uniform_float(jitter_key, static_cast<std::uint64_t>(x), static_cast<std::uint64_t>(y)) : 0.0f;
        const std::size_t pixel = static_cast<std::size_t>(y) * static_cast<std::size_t>(cam.width) + static_cast<std::size_t>(x);
        const float t_surface = in.opaque ? (*in.opaque->distance)[pixel] : kInfinity;
        float& half = out.half_depth[pixel];
        // the volumes' colour (premultiplied) and opacity over [t_start, t_end]
        auto one = [&](const PreparedVolume& pv, float t_start, float t_end, Rgb& color) {
          return pv.volume->with_voxel_type([&](auto type) {
            return in.owned ? trace_one<decltype(type), true>(pv, shader, ray, jitter, t_start, t_end, batch, color, half, counts)
                            : trace_one<decltype(type), false>(pv, shader, ray, jitter, t_start, t_end, batch, color, half, counts);
          });
        };
        auto trace = [&](float t_start, float t_end, Rgb& color) {
          float b0 = 0, b1 = 0;
          if (in.volumes.size() == 1 && in.refined && in.refined->span(ray, b0, b1, t_start, t_end)) {
            // the opened level in front of the box, the box, the opened level behind it: one lattice
            Rgb front(0.0f), box(0.0f), back(0.0f);
            const float a_front = b0 > t_start ? one(*in.volumes.front(), t_start, std::nextafter(b0, -kInfinity), front) : 0.0f;
            const float a_box = a_front < kEarlyTermination ? one(*in.refined, b0, b1, box) : 0.0f;
            const float clear = (1 - a_front) * (1 - a_box);
            const float a_back = 1 - clear < kEarlyTermination ? one(*in.volumes.front(), std::nextafter(b1, kInfinity), t_end, back) : 0.0f;
            color += front + box * (1 - a_front) + back * clear;
            return 1 - clear * (1 - a_back);
          }
          if (in.volumes.size() == 1) return one(*in.volumes.front(), t_start, t_end, color);
          if (in.volumes.empty()) return 0.0f;
          return trace_many(in.volumes, shader, ray, jitter, t_start, t_end, batch, overlap, color, half, counts);
        };
        const Rgb behind = in.opaque ? in.opaque->color->at(x, y) : in.scene->background;
        const float t_glass = in.translucent ? (*in.translucent->distance)[pixel] : kInfinity;
        Rgb color(0.0f);
        if (t_glass < t_surface) {
          // in front of the plane, the plane over what lies behind it, and behind it up to the surface;
          // the lattice is the same, split at the plane (a sample on it counts in front)
          const float front = trace(0, t_glass, color);
          Rgb back_color(0.0f);
          const float back = trace(std::nextafter(t_glass, kInfinity), t_surface, back_color);
          const float a = (*in.translucent->opacity)[pixel];
          const Rgb glass = in.translucent->color->at(x, y);
          out.image.at(x, y) = color + (glass * a + (back_color + behind * (1 - back)) * (1 - a)) * (1 - front);
          out.opacity[pixel] = 1 - (1 - front) * (1 - a) * (1 - back);
        } else {
          const float opacity = trace(0, t_surface, color);
          out.image.at(x, y) = color + behind * (1 - opacity);
          out.opacity[pixel] = opacity;
        }
      }
    }
    classified.fetch_add(counts.classified, std::memory_order_relaxed);
    shaded.fetch_add(counts.shaded, std::memory_order_relaxed);
    if (tile.x1 == cam.width) progress.advance(static_cast<std::size_t>(tile.y1 - tile.y0));
  });
  out.samples = classified.load();
  out.shaded_samples = shaded.load();
  return out;
}

}  // namespace penumbra
