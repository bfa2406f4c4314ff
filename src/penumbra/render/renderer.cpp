#include "penumbra/render/renderer.h"

#include "penumbra/core/timer.h"
#include "penumbra/render/volume_raycaster.h"
#include "penumbra/shadows/registry.h"

namespace penumbra {

Renderer::Renderer(const Scene& scene) : scene_(scene) {
  Timer timer;
  if (const VolumeObject* v = scene.visible_volume()) {
    volume_ = std::make_unique<PreparedVolume>(*v);
    medium_ = std::make_unique<ShadowMedium>(scene, volume_->grid);
  } else {
    planes_only_grid_ = std::make_unique<MacrocellGrid>();
    medium_ = std::make_unique<ShadowMedium>(scene, *planes_only_grid_);
  }
  prepare_ms_ = timer.elapsed_ms();
}

FrameResult Renderer::render(const Camera& camera, const std::vector<Light>& lights) {
  FrameResult frame;
  Timer total;
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
  frame.image = render_volume_frame(RayCastInputs{&scene_, &camera, volume_.get(), lights, shadow_ptrs});
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
