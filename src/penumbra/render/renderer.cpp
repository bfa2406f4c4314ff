#include "penumbra/render/renderer.h"

#include "penumbra/core/error.h"
#include "penumbra/core/timer.h"
#include "penumbra/render/volume_raycaster.h"
#include "penumbra/shadows/registry.h"

namespace penumbra {

Renderer::Renderer(Scene scene) : scene_(std::move(scene)) {
  Timer timer;
  prepare();
  prepare_ms_ = timer.elapsed_ms();
}

void Renderer::prepare() {
  medium_.reset();
  if (const VolumeObject* v = scene_.visible_volume()) {
    volume_ = std::make_unique<PreparedVolume>(*v);
    medium_ = std::make_unique<ShadowMedium>(scene_, volume_->grid);
  } else {
    planes_only_grid_ = std::make_unique<MacrocellGrid>();
    medium_ = std::make_unique<ShadowMedium>(scene_, *planes_only_grid_);
  }
  if (sat_) medium_->attach_extinction_sat(sat_.get());
}

void Renderer::set_transfer_function(const TransferFunction& tf) {
  const VolumeObject* visible = scene_.visible_volume();
  if (!visible) throw Error("set_transfer_function: the scene has no visible volume");
  for (auto& v : scene_.volumes)
    if (&v == visible) v.transfer_function = tf;
  prepare();
  transfer_function_changed_ = true;
}

FrameResult Renderer::render(const Camera& camera, const std::vector<Light>& lights) {
  FrameResult frame;
  Timer total;
  if (transfer_function_changed_) {
    const VolumeObject* v = scene_.visible_volume();
    if (needs_extinction_sat(scene_)) {
      if (!v) throw Error("shadows.technique / ambient.technique: the extinction techniques need a visible volume");
      Timer t;
      medium_->attach_extinction_sat(nullptr);
      sat_.reset();
      sat_ = std::make_unique<ExtinctionSat>(*v->volume, v->shadow_tf(), v->compositing, v->reference_step(),
                                             scene_.light_cache.resolution, needs_extinction_colour(scene_));
      medium_->attach_extinction_sat(sat_.get());
      frame.sat_ms = t.elapsed_ms();
      frame.rebuilt.push_back("sat");
    }
    if (auto ambient = make_ambient_technique(scene_.ambient)) {
      Timer t;
      ambient->build(*medium_);
      ambient_ = std::move(ambient);
      frame.ambient_ms = t.elapsed_ms();
      frame.rebuilt.push_back("ambient");
    }
    shadows_.clear();
    built_for_.clear();
    transfer_function_changed_ = false;
  }
  if (shadows_.size() != lights.size()) {
    shadows_.clear();
    built_for_.clear();
  }
  Timer build;
  bool rebuilt = false;
  for (std::size_t i = 0; i < lights.size(); ++i) {
    if (i < shadows_.size() && built_for_[i] == lights[i]) continue;
    auto technique = make_shadow_technique(scene_.shadows);
    technique->build(*medium_, lights[i]);
    if (i < shadows_.size()) {
      shadows_[i] = std::move(technique);
      built_for_[i] = lights[i];
    } else {
      shadows_.push_back(std::move(technique));
      built_for_.push_back(lights[i]);
    }
    rebuilt = true;
  }
  frame.build_ms = build.elapsed_ms();
  if (rebuilt) frame.rebuilt.push_back("shadows");

  std::vector<const ShadowTechnique*> shadow_ptrs;
  for (const auto& s : shadows_) shadow_ptrs.push_back(s.get());
  Timer render;
  frame.image = render_volume_frame(RayCastInputs{&scene_, &camera, volume_.get(), lights, shadow_ptrs, ambient_.get()});
  frame.render_ms = render.elapsed_ms();
  frame.total_ms = total.elapsed_ms();
  return frame;
}

std::size_t Renderer::shadow_memory_bytes() const {
  std::size_t bytes = 0;
  for (const auto& s : shadows_) bytes += s->memory_bytes();
  return bytes;
}

}  // namespace penumbra
