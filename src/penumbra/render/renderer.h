// Renders frames of a scene and keeps what can be reused between frames: the prepared volume (transfer
// function table, macrocells) lives as long as the renderer; each light's shadow structure is rebuilt
// only when that light changed. Frames report what they rebuilt, for `--stats` and `--orbit`.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "penumbra/core/image.h"
#include "penumbra/render/prepared_volume.h"
#include "penumbra/scene/scene.h"
#include "penumbra/shadows/shadow_medium.h"
#include "penumbra/shadows/shadow_technique.h"

namespace penumbra {

struct FrameResult {
  Image image;
  double build_ms = 0;   // shadow generation (all lights) this frame
  double render_ms = 0;  // ray casting
  double total_ms = 0;
  std::vector<std::string> rebuilt;  // "shadows" when any light's structure was rebuilt
};

class Renderer {
public:
  explicit Renderer(const Scene& scene);  // the scene must outlive the renderer

  // Renders with the given camera and lights (the scene's by default).
  FrameResult render(const Camera& camera, const std::vector<Light>& lights);
  FrameResult render() { return render(scene_.camera, scene_.lights); }

  std::size_t shadow_memory_bytes() const;
  std::size_t voxel_count() const { return volume_ ? volume_->volume->voxel_count() : 0; }
  double prepare_ms() const { return prepare_ms_; }

private:
  const Scene& scene_;
  std::unique_ptr<PreparedVolume> volume_;
  std::unique_ptr<MacrocellGrid> planes_only_grid_;
  std::unique_ptr<ShadowMedium> medium_;
  std::vector<std::unique_ptr<ShadowTechnique>> shadows_;
  std::vector<Light> built_for_;
  double prepare_ms_ = 0;
};

}  // namespace penumbra
