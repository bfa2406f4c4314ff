#include "penumbra/isosurface/light_pass.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>

#include "penumbra/core/error.h"
#include "penumbra/core/timer.h"
#include "penumbra/lighting/shared_params.h"

namespace penumbra {

LightFrustum light_frustum_from_string(const std::string& name) {
  if (name == "tight") return LightFrustum::Tight;
  if (name == "volume") return LightFrustum::Volume;
  throw Error("unknown light frustum '" + name + "' (expected 'tight' or 'volume')");
}

std::string to_string(LightFrustum f) { return f == LightFrustum::Tight ? "tight" : "volume"; }

namespace {

// The share of the two points' position errors the bias allows for: a cell point's distance from the
// surface is typically well below the cell's diagonal that bounds it.
constexpr float kErrorShare = 0.5f;

// Bounds of the points' image-plane coordinates in `view`'s frame (x/z, y/z for perspective).
struct Window {
  float left = kInfinity, right = -kInfinity, bottom = kInfinity, top = -kInfinity;
  void extend(float sx, float sy) {
    left = std::min(left, sx);
    right = std::max(right, sx);
    bottom = std::min(bottom, sy);
    top = std::max(top, sy);
  }
  bool empty() const { return left > right; }
};

bool image_plane(const ViewProjection& v, const Vec3& p, float& sx, float& sy) {
  const Vec3 d = p - v.eye;
  sx = dot(d, v.frame.u);
  sy = dot(d, v.frame.v);
  if (v.orthographic) return true;
  const float z = -dot(d, v.frame.w);
  if (!(z > 0)) return false;
  sx /= z;
  sy /= z;
  return true;
}

// The receivers' mean position. Each coordinate is put on a grid of 2^-20 of the box's longest side
// (clamped to ±2^30 steps) and summed as integers: the sum is the same in any order and over any split
// of the receivers across bricks (whole numbers below 2^53 add exactly in doubles). Unset when no
// receiver (on any brick).
std::optional<Vec3> mean_position(std::span<const IsoPoint> receivers, const Box3& box, BrickReduction* reduction) {
  const Vec3 e = box.extent();
  const float step = std::max({e.x, e.y, e.z, 1e-6f}) / static_cast<float>(1 << 20);
  const auto steps = [&](float v, float lo) {
    return std::clamp<std::int64_t>(std::llround(static_cast<double>(v - lo) / step), -(std::int64_t{1} << 30), std::int64_t{1} << 30);
  };
  std::int64_t sum[3] = {0, 0, 0};
  for (const IsoPoint& p : receivers) {
    sum[0] += steps(p.position.x, box.lo.x);
    sum[1] += steps(p.position.y, box.lo.y);
    sum[2] += steps(p.position.z, box.lo.z);
  }
  double totals[] = {static_cast<double>(sum[0]), static_cast<double>(sum[1]), static_cast<double>(sum[2]),
                     static_cast<double>(receivers.size())};
  if (reduction) reduction->sum(totals);
  if (totals[3] == 0) return std::nullopt;
  const auto coordinate = [&](int a, float lo) { return lo + static_cast<float>(totals[a] / totals[3] * step); };
  return Vec3{coordinate(0, box.lo.x), coordinate(1, box.lo.y), coordinate(2, box.lo.z)};
}

}  // namespace

ViewProjection fit_light_view(const Light& light, std::span<const IsoPoint> receivers, const Box3& volume_box,
                              const LightPassSettings& settings, BrickReduction* reduction) {
  ViewProjection v;
  v.width = v.height = settings.resolution;
  v.orthographic = light.type == LightType::Directional;
  // The line of sight: from the light to the centre of what the frustum must hold (§4.3).
  Vec3 centre = volume_box.center();
  if (settings.frustum == LightFrustum::Tight)
    if (const std::optional<Vec3> mean = mean_position(receivers, volume_box, reduction)) centre = *mean;
  const float reach = length(volume_box.extent()) + 1e-3f;
  if (v.orthographic) {
    const Vec3 forward = normalize(light.direction);
    v.frame = Frame::from_w(-forward);
    // the view plane behind everything that can cast a shadow
    v.eye = centre - forward * (length(centre - volume_box.center()) + reach);
  } else {
    v.eye = light.position;
    const Vec3 to_centre = centre - light.position;
    v.frame = Frame::from_w(length(to_centre) > 0 ? -normalize(to_centre) : Vec3{0, 0, 1});
  }
  Window w;
  float sx, sy;
  if (settings.frustum == LightFrustum::Tight) {
    for (const IsoPoint& p : receivers)
      if (image_plane(v, p.position, sx, sy)) w.extend(sx, sy);
  } else {
    for (int c = 0; c < 8; ++c) {
      const Vec3 p{(c & 1) ? volume_box.hi.x : volume_box.lo.x, (c & 2) ? volume_box.hi.y : volume_box.lo.y,
                   (c & 4) ? volume_box.hi.z : volume_box.lo.z};
      if (!image_plane(v, p, sx, sy))
        throw Error("shadows.light_frustum = volume: the light is inside or beside the volume box; use 'tight'");
      w.extend(sx, sy);
    }
  }
  if (reduction) {  // the window holding every brick's receivers
    float bounds[] = {w.left, w.bottom, -w.right, -w.top};
    reduction->minimum(bounds);
    w = Window{bounds[0], -bounds[2], bounds[1], -bounds[3]};
  }
  if (w.empty()) w.extend(0, 0);
  // A margin of half a pixel, so that the outermost points fall inside the buffer, and a minimum size.
  const float size = std::max({w.right - w.left, w.top - w.bottom, 1e-6f});
  const float pad = 0.5f * size / static_cast<float>(settings.resolution) + 1e-7f;
  v.left = w.left - pad;
  v.right = std::max(w.right, w.left + 1e-6f) + pad;
  v.bottom = w.bottom - pad;
  v.top = std::max(w.top, w.bottom + 1e-6f) + pad;
  return v;
}

void LightPass::build(const ShadowCasters& casters, const Light& light) {
  casters_ = &casters;
  light_ = light;
  passes_.clear();
}

void LightPass::fit_to_receivers(std::span<const SurfacePoint> receivers, bool volume_samples, bool refined) {
  Timer timer;
  // Only receivers facing the light need an answer (the others get no light whatever lies in front of
  // them): the frustum is fitted to them and only they punch holes.
  std::vector<IsoPoint> facing;
  facing.reserve(receivers.size());
  for (const SurfacePoint& p : receivers) {
    Vec3 to_light;
    float distance;
    light_.towards(p.position, to_light, distance);
    if (dot(p.normal, to_light) > 0) facing.push_back(IsoPoint{p.position, p.normal, 0, 0, p.error});
  }
  LightPassSettings settings = settings_;
  if (volume_samples) settings.frustum = LightFrustum::Volume;
  // On a brick of a data-parallel frame: the fit, the holes and the depths combine over the bricks
  BrickReduction* const reduction = casters_->brick() ? casters_->brick()->reduction : nullptr;
  passes_.assign(casters_->isosurfaces().size(), IsosurfaceLightPass{});
  for (std::size_t s = 0; s < passes_.size(); ++s) {
    const CastingIsosurface& iso = casters_->isosurfaces()[s];
    IsosurfaceLightPass& pass = passes_[s];
    pass.view = fit_light_view(light_, facing, iso.bounds, settings, reduction);
    // §4.2: all non-visible, then one hole per receiver's light pixel (every pixel for volume samples).
    pass.holes = VisibilityBuffer(pass.view.width, pass.view.height, volume_samples);
    const std::size_t pixels = static_cast<std::size_t>(pass.view.width) * static_cast<std::size_t>(pass.view.height);
    std::vector<float> closed(reduction && !volume_samples ? pixels : 0, 1.0f);  // 0: a hole (any brick's)
    if (!volume_samples)
      for (const IsoPoint& p : facing) {
        float px, py;
        if (!pass.view.project(p.position, px, py)) continue;
        const int x = static_cast<int>(std::floor(px)), y = static_cast<int>(std::floor(py));
        if (x < 0 || y < 0 || x >= pass.view.width || y >= pass.view.height) continue;
        if (reduction) closed[static_cast<std::size_t>(y) * static_cast<std::size_t>(pass.view.width) + static_cast<std::size_t>(x)] = 0;
        else pass.holes.set_visible(x, y);
      }
    if (!closed.empty()) {
      reduction->minimum(closed);
      for (std::size_t k = 0; k < pixels; ++k)
        if (closed[k] == 0) pass.holes.set_visible(static_cast<int>(k % static_cast<std::size_t>(pass.view.width)),
                                                   static_cast<int>(k / static_cast<std::size_t>(pass.view.width)));
    }
    pass.hole_count = pass.holes.visible_count();
    pass.crease = 2 * iso.offset;  // (the offset: a twentieth of the voxel)
    ExtractionOptions options;
    options.collapse = false;  // §4.3: a far-subvolume point would shadow the receivers around it
    options.normals = false;
    options.start = &pass.holes;
    options.clip = &iso.clip;
    // a refined box: its surface from its own hierarchy, the opened level's kept out of it (as in the eye pass)
    const GridTree* finer = refined ? iso.finer.tree : nullptr;
    if (finer) options.exclude = &iso.finer_box;
    pass.light_points = extract_points(*iso.tree, iso.isovalue, pass.view, options);
    const std::size_t opened_points = pass.light_points.points.size();  // the box's points follow
    if (finer) {
      options.exclude = nullptr;
      const Extraction inside = extract_points(*finer, iso.isovalue, pass.view, options);
      pass.light_points.points.insert(pass.light_points.points.end(), inside.points.begin(), inside.points.end());
      pass.light_points.stats.add(inside.stats);
      pass.light_points.stats.ms += inside.stats.ms;
    }
    pass.depth.assign(static_cast<std::size_t>(pass.view.width) * static_cast<std::size_t>(pass.view.height), kInfinity);
    pass.depth_error.assign(pass.depth.size(), 0);
    // the box's own crease where its points are the nearest (not over bricks: a brick's nearest point
    // may be another's, so the opened level's crease, the larger, stays there)
    if (finer && !reduction) {
      pass.finer_point.assign(pass.depth.size(), 0);
      pass.finer_box = iso.finer_box;
      pass.finer_crease = 2 * isosurface_offset(finer->volume().spacing());
    }
    for (std::size_t i = 0; i < pass.light_points.points.size(); ++i) {  // one point per pixel and pass: the nearer
      const IsoPoint& p = pass.light_points.points[i];
      if (p.distance < pass.depth[p.pixel]) {
        pass.depth[p.pixel] = p.distance;
        pass.depth_error[p.pixel] = p.error;
        if (!pass.finer_point.empty()) pass.finer_point[p.pixel] = i >= opened_points;
      }
    }
    if (reduction) {  // per light pixel the nearest of the bricks' points, with that point's error
      std::vector<float> nearest = pass.depth;
      reduction->minimum(nearest);
      for (std::size_t k = 0; k < pixels; ++k)
        if (pass.depth[k] != nearest[k]) pass.depth_error[k] = kInfinity;
      reduction->minimum(pass.depth_error);
      for (std::size_t k = 0; k < pixels; ++k)
        if (nearest[k] == kInfinity) pass.depth_error[k] = 0;
      pass.depth = std::move(nearest);
    }
  }
  build_ms_ = timer.elapsed_ms();
}

// The receiver and the light point of its pixel both lie on the surface, but not at the same place:
// the light point sits on the pixel's central ray, the receiver anywhere in the pixel's footprint, so on
// a surface tilted by theta to the light their distances differ by up to half a pixel's diagonal times
// tan(theta) — we allow a whole pixel (measured on the CT bone surfaces: 0.5 leaves 3 % of the lit
// points in false shadow on the cranium, 1.0 0.3 %); a point from a sub-pixel cell (or a collapsed node) is on the surface only to within
// that cell, which each point carries as its `error`; and across a crease of the trilinear surface the
// light point may lie on a steeper facet than the receiver, which `crease` (a tenth of a voxel) allows
// for (LightPass.NoAcneOnTheCreasesOfAVoxelisedSurface). The bias covers all three.
float LightPass::bias(const ViewProjection& view, float distance, float cos_theta, float error, float light_error, float crease) const {
  if (settings_.bias >= 0) return settings_.bias;
  const float c = std::max(std::abs(cos_theta), 0.1f);
  const float tan_theta = std::sqrt(std::max(0.0f, 1 - c * c)) / c;
  return kErrorShare * (error + light_error) + view.pixel_size(distance) * tan_theta + crease;
}

float LightPass::light_at(const Vec3& position, float cos_theta, float error) const {
  for (const IsosurfaceLightPass& pass : passes_) {
    float px, py;
    if (!pass.view.project(position, px, py)) continue;
    const int x = static_cast<int>(std::floor(px)), y = static_cast<int>(std::floor(py));
    if (x < 0 || y < 0 || x >= pass.view.width || y >= pass.view.height) continue;
    const std::size_t k = static_cast<std::size_t>(y) * static_cast<std::size_t>(pass.view.width) + static_cast<std::size_t>(x);
    if (pass.depth[k] == kInfinity) continue;
    const float d = pass.view.distance(position);
    if (d > pass.depth[k] + bias(pass.view, d, cos_theta, error, pass.depth_error[k], pass.crease_at(k, position))) return 0;
  }
  return 1;
}

void LightPass::transmittance(std::span<const Vec3> points, std::span<Rgb> out) const {
  for (std::size_t i = 0; i < points.size(); ++i) out[i] = Rgb(light_at(points[i], 1, 0));
}

void LightPass::transmittance(std::span<const SurfacePoint> points, std::span<Rgb> out) const {
  for (std::size_t i = 0; i < points.size(); ++i) {
    const SurfacePoint& p = points[i];
    Vec3 to_light;
    float distance;
    light_.towards(p.position, to_light, distance);
    out[i] = Rgb(light_at(p.position, dot(p.normal, to_light), p.error));
  }
}

void LightPass::add_stats(ShadowStats& stats) const {
  for (const IsosurfaceLightPass& pass : passes_) {
    stats.light_points += pass.light_points.points.size();
    stats.holes += pass.hole_count;
  }
}

std::size_t LightPass::memory_bytes() const {
  std::size_t bytes = 0;
  for (const IsosurfaceLightPass& pass : passes_)
    bytes += pass.depth.size() * 2 * sizeof(float) + pass.finer_point.size() + pass.light_points.points.size() * sizeof(IsoPoint) +
             static_cast<std::size_t>(pass.view.width) * static_cast<std::size_t>(pass.view.height) / 8;
  return bytes;
}

namespace {
const ParamSpec kLightFrustum = choice_param("light_frustum", "tight", {"tight", "volume"},
                                             "the light's view: fitted to the receivers' eye points (§4.3) or the volume's box");
}  // namespace

const TechniqueInfo& light_pass_technique() {
  static const TechniqueInfo info{
      "light_pass", TechniqueFamily::Shadow, kind_bit(ObjectKind::Isosurface),
      "view-dependent light pass: the receivers' isosurface points seen from the light (Livnat & Tricoche, paper 002 §4)",
      {kMapResolution, kMapBias, kLightFrustum},
      {},
      [](const TechniqueParams& p) -> std::unique_ptr<ShadowTechnique> {
        return std::make_unique<LightPass>(LightPassSettings{static_cast<int>(kMapResolution.integer(p)), light_frustum_from_string(kLightFrustum.choice(p)),
                                                             static_cast<float>(kMapBias.number(p))});
      },
      {}};
  return info;
}

}  // namespace penumbra
