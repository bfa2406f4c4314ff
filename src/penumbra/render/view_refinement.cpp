#include "penumbra/render/view_refinement.h"

#include <algorithm>
#include <cmath>

#include "penumbra/core/error.h"
#include "penumbra/core/timer.h"

namespace penumbra {
namespace {

float smallest_edge(const Vec3& spacing) { return std::min(spacing.x, std::min(spacing.y, spacing.z)); }

}  // namespace

Box3 visible_part(const Camera& camera, const Box3& box, float far) {
  Box3 seen;
  if (box.empty()) return seen;
  const PrimaryRays rays(camera);
  const auto w = static_cast<float>(camera.width), h = static_cast<float>(camera.height);
  // the frustum's four edges, around the image, and its sides' inward normals
  const std::array<Vec3, 4> edge{rays.direction(0.0f, 0.0f), rays.direction(w, 0.0f), rays.direction(w, h), rays.direction(0.0f, h)};
  const Vec3 ahead = -rays.frame.w;  // depth is measured along it
  std::array<Vec3, 4> side{};
  for (std::size_t i = 0; i < 4; ++i) {
    side[i] = normalize(cross(edge[i], edge[(i + 1) % 4]));
    if (dot(side[i], ahead) < 0) side[i] = -side[i];
  }
  const Vec3 eye = camera.eye;
  const float slack = 1e-5f * (box.radius() + length(eye - box.center()));
  // inside every side but `except` (4: none) and nearer than `far` (unless `except` is 5, the far plane)
  auto in_frustum = [&](const Vec3& p, std::size_t except) {
    for (std::size_t i = 0; i < 4; ++i)
      if (i != except && dot(side[i], p - eye) < -slack) return false;
    return except == 5 || dot(ahead, p - eye) <= far + slack;
  };
  if (box.contains(eye)) seen.extend(eye);
  for (int c = 0; c < 8; ++c)
    if (in_frustum(box.corner(c), 4)) seen.extend(box.corner(c));
  for (const Vec3& d : edge) {  // the frustum's edges, up to the far plane
    float t0 = 0, t1 = 0;
    if (box.clip(Ray{eye, d}, t0, t1, 0.0f, far / dot(d, ahead))) {
      seen.extend(eye + d * t0);
      seen.extend(eye + d * t1);
    }
  }
  for (int a = 0; a < 8; ++a)
    for (int bit = 1; bit < 8; bit <<= 1) {
      if (a & bit) continue;
      const Vec3 p = box.corner(a), q = box.corner(a | bit);
      for (std::size_t i = 0; i < 5; ++i) {  // the box's edges through the sides and the far plane
        const float dp = i < 4 ? dot(side[i], p - eye) : far - dot(ahead, p - eye);
        const float dq = i < 4 ? dot(side[i], q - eye) : far - dot(ahead, q - eye);
        if ((dp < 0) == (dq < 0) || !std::isfinite(dp - dq)) continue;
        const Vec3 x = p + (q - p) * (dp / (dp - dq));
        if (in_frustum(x, i == 4 ? 5 : i)) seen.extend(x);
      }
    }
  if (seen.empty()) return seen;
  seen.lo = max(seen.lo, box.lo);  // rounding may put a point a hair outside
  seen.hi = min(seen.hi, box.hi);
  return seen;
}

bool LevelBox::contains(const LevelBox& b) const {
  for (std::size_t a = 0; a < 3; ++a)
    if (b.lo[a] < lo[a] || b.hi[a] > hi[a]) return false;
  return level == b.level;
}

bool overlaps(const LevelBox& a, const LevelBox& b) {
  for (std::size_t k = 0; k < 3; ++k)
    if (a.hi[k] <= b.lo[k] || b.hi[k] <= a.lo[k]) return false;
  return a.level == b.level;
}

LevelBox level_box(const PyramidSource& pyramid, int level, const Box3& world) {
  const PyramidSource::Level& l = pyramid.levels.at(static_cast<std::size_t>(level));
  LevelBox b;
  b.level = level;
  for (int a = 0; a < 3; ++a) {
    const auto n = static_cast<std::int64_t>(l.dims[static_cast<std::size_t>(a)]);
    const double lo = std::floor((static_cast<double>(world.lo[a]) - l.origin[a]) / l.spacing[a]);
    const double hi = std::floor((static_cast<double>(world.hi[a]) - l.origin[a]) / l.spacing[a]);
    // the cells [lo, hi] reach into the box: voxels lo to hi + 1, and the apron
    std::int64_t first = static_cast<std::int64_t>(std::clamp(lo, -1.0, static_cast<double>(n))) - kRefinementApron;
    std::int64_t end = static_cast<std::int64_t>(std::clamp(hi, -1.0, static_cast<double>(n))) + 2 + kRefinementApron;
    first = std::clamp<std::int64_t>(first, 0, n - 1);
    end = std::clamp<std::int64_t>(end, first + 1, n);
    if (end - first < 2 && n >= 2) first = std::max<std::int64_t>(0, end - 2), end = first + 2;  // a cell to interpolate in
    b.lo[static_cast<std::size_t>(a)] = first;
    b.hi[static_cast<std::size_t>(a)] = end;
  }
  return b;
}

std::uint64_t refined_bytes(const LevelBox& box, ScalarType type, bool gradients) {
  const std::array<std::int64_t, 3> d{box.hi[0] - box.lo[0], box.hi[1] - box.lo[1], box.hi[2] - box.lo[2]};
  const auto voxels = static_cast<std::uint64_t>(d[0] * d[1] * d[2]);
  return volume_held_bytes(d, type) + (gradients ? voxels * kGradientBytesPerVoxel : 0);
}

std::optional<RefinementChoice> choose_refinement(const Camera& camera, const PyramidSource& pyramid, const Box3& volume_box,
                                                  std::uint64_t bytes, bool gradients, bool cut_depth) {
  if (pyramid.opened <= 0) return std::nullopt;
  const PrimaryRays rays(camera);
  const Vec3 ahead = -rays.frame.w;
  const float per_depth = 2.0f * std::tan(radians(camera.fov_deg) * 0.5f) / static_cast<float>(std::max(camera.height, 1));  // a pixel's size
  auto edge = [&](int level) { return smallest_edge(pyramid.levels[static_cast<std::size_t>(level)].spacing); };
  // beyond this depth the opened level's voxel is no larger than a pixel: nothing there to refine
  const float enough = edge(pyramid.opened) / per_depth;
  const Box3 visible = visible_part(camera, volume_box, enough);
  if (visible.empty()) return std::nullopt;
  float near = kInfinity, far = 0;
  for (int c = 0; c < 8; ++c) {
    const float d = dot(visible.corner(c) - camera.eye, ahead);
    near = std::min(near, d);
    far = std::max(far, d);
  }
  near = std::max(near, 0.0f);
  far = std::min(far, enough);
  const float pixel = std::max(0.0f, dot(visible.center() - camera.eye, ahead)) * per_depth;
  // the level's box of `seen` (grown by the margin when `margin`) when it fits the bytes
  auto fit = [&](const Box3& seen, int level, bool margin) -> std::optional<RefinementChoice> {
    const Vec3 m = margin ? seen.extent() * kRefinementMargin : Vec3{0, 0, 0};
    const LevelBox box = level_box(pyramid, level, Box3{seen.lo - m, seen.hi + m});
    const auto d = box.dims();
    const std::uint64_t voxels = static_cast<std::uint64_t>(d[0]) * static_cast<std::uint64_t>(d[1]) * static_cast<std::uint64_t>(d[2]);
    const bool stored = gradients && refined_bytes(box, pyramid.type, true) <= bytes && voxels * kGradientBytesPerVoxel <= kStoredGradientBytes;
    if (!stored && refined_bytes(box, pyramid.type, false) > bytes) return std::nullopt;
    return RefinementChoice{box, stored, seen};
  };
  // the margin is kept where it fits, so that a small camera move stays inside the box
  std::optional<RefinementChoice> best;
  for (int level = pyramid.opened - 1; level >= 0; --level) {
    std::optional<RefinementChoice> whole = fit(visible, level, true);
    if (!whole) whole = fit(visible, level, false);
    if (whole) {
      best = whole;
      if (edge(level) <= pixel) break;
      continue;
    }
    // the near part of the view that fits, with its margin if it can (at least a quarter of the view's
    // depth); the rest stays on the opened level
    float lo = near + 0.25f * (far - near), hi = far;
    std::optional<RefinementChoice> part;
    bool margin = true;
    if (cut_depth) {
      part = fit(visible_part(camera, volume_box, lo), level, true);
      if (!part) part = fit(visible_part(camera, volume_box, lo), level, margin = false);
    }
    for (int i = 0; part && i < 12; ++i) {
      const float mid = 0.5f * (lo + hi);
      if (const auto deeper = fit(visible_part(camera, volume_box, mid), level, margin)) {
        part = deeper;
        lo = mid;
      } else {
        hi = mid;
      }
    }
    if (part) best = part;
    break;
  }
  return best;
}

nlohmann::json refinement_json(const std::vector<RefinementStats>& refinement) {
  nlohmann::json out = nlohmann::json::array();
  for (const RefinementStats& r : refinement) {
    nlohmann::json entry = {{"volume", r.volume}, {"opened_level", r.opened_level}, {"level", r.level}, {"dims", r.dims},
                            {"held_bytes", r.held_bytes}, {"loaded_bytes", r.loaded_bytes}, {"read_bytes", r.read_bytes},
                            {"reused_bytes", r.reused_bytes}, {"evicted_bytes", r.evicted_bytes}, {"kept_bytes", r.kept_bytes},
                            {"load_ms", r.load_ms}};
    if (!r.error.empty()) entry["error"] = r.error;
    out.push_back(std::move(entry));
  }
  return out;
}

bool FailedRefinement::covers(const PyramidSource& pyramid, const RefinementChoice& choice) const {
  return key == pyramid.key && box.level == choice.box.level &&
         box.contains(level_box(pyramid, box.level, choice.seen));
}

bool box_serves(const LevelBox& held, std::uint64_t held_bytes, const PyramidSource& pyramid, const std::optional<RefinementChoice>& choice,
                std::uint64_t left) {
  return choice && held.level <= choice->box.level && held.contains(level_box(pyramid, held.level, choice->seen)) && held_bytes <= left;
}

bool read_refinement_box(const RefinementChoice& choice, const std::string& key, const std::function<std::uint64_t(WindowRead&)>& read,
                         RefinementStats& stats, std::optional<FailedRefinement>& failed) {
  const Timer load;
  WindowRead window;
  try {
    stats.loaded_bytes = read(window);
  } catch (const Error& e) {
    const std::array<int, 3> d = choice.box.dims();
    failed = FailedRefinement{choice.box, key,
                              "level " + std::to_string(choice.box.level) + " box " + std::to_string(d[0]) + "x" + std::to_string(d[1]) + "x" +
                                  std::to_string(d[2]) + ": " + e.what()};
    stats.error = failed->error;
    return false;
  }
  failed.reset();
  stats.read_bytes = window.bytes_read;
  stats.reused_bytes = window.bytes_reused;
  stats.load_ms = load.elapsed_ms();
  return true;
}

RefinedVolume::RefinedVolume(const VolumeObject& coarse, const RefinementChoice& choice, WindowRead* read, const RefinedVolume* previous,
                             std::unique_ptr<RefinedVolume> moving)
    : box_(choice.box), key_(coarse.pyramid->key), object_(coarse) {
  const PyramidSource& pyramid = *coarse.pyramid;
  if (moving) previous = moving.get();
  std::optional<HeldBox> held;
  if (previous && previous->reads(pyramid) && previous->box_.level == box_.level) {
    held = HeldBox{previous->box_.lo, previous->box_.hi, previous->voxels_.get()};
    if (moving && moving->voxels_.use_count() == 2) {  // its own and its object's
      moving->prepared_.reset();  // its gradients and cells go before this box's are made
      held->storage = moving->voxels_.get();
    }
  }
  Volume box = pyramid.read_box(box_.level, box_.lo, box_.hi, read, held ? &*held : nullptr);
  moving.reset();
  box.set_value_range(std::min(box.min_value(), coarse.volume->min_value()), std::max(box.max_value(), coarse.volume->max_value()));
  voxels_ = std::make_shared<Volume>(std::move(box));
  object_.volume = voxels_;
  object_.pyramid = nullptr;
  object_.gradients = choice.stored_gradients ? VolumeObject::Gradients::Stored : VolumeObject::Gradients::OnTheFly;
  prepared_ = std::make_unique<PreparedVolume>(object_);
}

bool RefinedVolume::follow(const VolumeObject& coarse) {
  const bool table = !(coarse.transfer_function == object_.transfer_function) || coarse.compositing != object_.compositing;
  const VolumeObject::Gradients gradients = object_.gradients;
  object_ = coarse;
  object_.volume = voxels_;
  object_.pyramid = nullptr;
  object_.gradients = gradients;
  return table;
}

std::uint64_t RefinedVolume::held_bytes() const {
  return refined_bytes(box_, object_.volume->type(), object_.gradients == VolumeObject::Gradients::Stored);
}

}  // namespace penumbra
