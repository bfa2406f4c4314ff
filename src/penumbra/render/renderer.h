// Renders frames of a scene and keeps what can be reused between frames (paper 001, Algorithm 1): the
// prepared volume (transfer-function table, macrocells) and the extinction SAT live until the transfer
// function changes; the ambient cache too; each light's shadow structure is rebuilt only when that
// light or the transfer function changed. Moving the camera rebuilds nothing. Frames report what they
// rebuilt and how long it took, for `--stats`, `--orbit` and `--light-orbit`.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "penumbra/accel/extinction_sat.h"
#include "penumbra/core/image.h"
#include "penumbra/particles/sphere_bvh.h"
#include "penumbra/particles/sphere_shadow_technique.h"
#include "penumbra/render/isosurface_frame.h"
#include "penumbra/render/prepared_volume.h"
#include "penumbra/scene/scene.h"
#include "penumbra/shadows/ambient_technique.h"
#include "penumbra/shadows/shadow_medium.h"
#include "penumbra/shadows/shadow_technique.h"

namespace penumbra {

struct FrameResult {
  Image image;
  double sat_ms = 0;      // extinction volume + summed area table, when rebuilt this frame
  double ambient_ms = 0;  // ambient-occlusion cache, when rebuilt this frame
  double build_ms = 0;    // shadow structures of the lights rebuilt this frame
  double render_ms = 0;   // ray casting (spheres: finding and shading the visible surfaces)
  double bvh_ms = 0;      // spheres: Embree BVH, when built this frame
  double hits_ms = 0;     // spheres: each pixel's nearest sphere (splatting or Embree rays)
  int issm_rings = -1;    // spheres: the rings t the ISSM used (chosen this frame when automatic)
  std::size_t sphere_pixels = 0;  // pixels showing a sphere
  IsosurfaceFrameStats isosurface;  // isosurface scenes: eye pass, shadow passes, counts
  double total_ms = 0;
  std::vector<std::string> rebuilt;  // "sat", "ambient", "shadows": what this frame had to rebuild
};

class Renderer {
public:
  explicit Renderer(Scene scene);  // keeps its own copy (volumes are shared, not copied)

  // Renders with the given camera and lights (the scene's by default).
  FrameResult render(const Camera& camera, const std::vector<Light>& lights);
  FrameResult render() { return render(scene_.camera, scene_.lights); }

  // Replaces the visible volume's transfer function (its shadow transfer function too, unless it has a
  // separate one): the next frame rebuilds the SAT, the ambient cache and every light's shadows.
  void set_transfer_function(const TransferFunction& tf);

  const Scene& scene() const { return scene_; }
  std::size_t shadow_memory_bytes() const;
  std::size_t ambient_memory_bytes() const {
    return ambient_ ? ambient_->memory_bytes() : (particle_ambient_ ? particle_ambient_->memory_bytes() : 0);
  }
  std::size_t sat_memory_bytes() const { return sat_ ? sat_->memory_bytes() : 0; }
  std::size_t voxel_count() const {
    if (volume_) return volume_->volume->voxel_count();
    return isosurfaces_.empty() ? 0 : isosurfaces_.front()->tree->volume().voxel_count();
  }
  std::size_t sphere_count() const { return particles_ ? particles_->size() : 0; }
  std::size_t particle_memory_bytes() const { return particles_ ? particles_->memory_bytes() : 0; }
  std::size_t bvh_memory_bytes() const { return bvh_ ? bvh_->memory_bytes() : 0; }
  double prepare_ms() const { return prepare_ms_; }
  // Isosurface scenes: each isosurface with its min/max hierarchy, and the shadow techniques of the
  // last frame (for each light, one per isosurface).
  const std::vector<std::unique_ptr<PreparedIsosurface>>& isosurfaces() const { return isosurfaces_; }
  const std::vector<std::unique_ptr<IsoShadowTechnique>>& isosurface_shadows() const { return isosurface_shadows_; }
  const IsoPoints& isosurface_eye_points() const { return isosurface_eye_points_; }

private:
  void prepare();  // prepared volume and shadow medium for the current transfer function
  void prepare_particles();  // one particle set of all the scene's particle objects
  void prepare_isosurfaces();
  // Rebuilds the shadow structures of the lights that changed; true when any was rebuilt.
  bool update_volume_shadows(const std::vector<Light>& lights);
  bool update_sphere_shadows(const std::vector<Light>& lights);
  Image render_particles(const Camera& camera, const std::vector<Light>& lights, FrameResult& frame);
  bool has_surfaces() const { return scene_.has_particles() || scene_.has_isosurfaces(); }

  Scene scene_;
  std::unique_ptr<PreparedVolume> volume_;
  std::unique_ptr<MacrocellGrid> planes_only_grid_;
  std::unique_ptr<ShadowMedium> medium_;
  std::unique_ptr<ExtinctionSat> sat_;
  std::unique_ptr<AmbientTechnique> ambient_;
  std::vector<std::unique_ptr<ShadowTechnique>> shadows_;
  std::vector<Light> built_for_;
  std::shared_ptr<const ParticleSet> particles_;
  std::unique_ptr<SphereBvh> bvh_;
  ParticleScene particle_scene_;
  std::unique_ptr<ParticleAmbientTechnique> particle_ambient_;
  std::vector<std::unique_ptr<SphereShadowTechnique>> sphere_shadows_;
  std::vector<Light> sphere_shadows_for_;
  bool particles_built_ = false;
  std::vector<std::unique_ptr<PreparedIsosurface>> isosurfaces_;  // sharing one GridTree per volume
  std::vector<std::unique_ptr<IsoShadowTechnique>> isosurface_shadows_;
  IsoPoints isosurface_eye_points_;  // the last frame's eye pass
  std::vector<float> opaque_distance_;  // the last sphere frame's per-pixel surface distance
  bool transfer_function_changed_ = true;  // the SAT and ambient cache are stale
  double prepare_ms_ = 0;
};

}  // namespace penumbra
