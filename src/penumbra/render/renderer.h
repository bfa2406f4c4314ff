// Renders frames of a scene — any mix of volumes, isosurfaces, spheres and planes — and keeps what can
// be reused between frames (paper 001, Algorithm 1). One pipeline for every kind:
//   1. the casters (ShadowCasters: every object that casts, with its acceleration structures) and,
//      per light, a LightShadows (one technique per group of caster kinds), rebuilt only when that
//      light or the transfer function changed;
//   2. the opaque surfaces: each pixel's nearest sphere (splatting or Embree), isosurface point (the
//      eye pass) or plane, shaded under the lights' shadows (surface_frame.h);
//   3. the visible volumes ray cast in front of them, every sample shadowed by the same LightShadows.
// The prepared volumes (transfer-function tables, macrocells, gradients) and the extinction SAT live
// until the transfer function changes, the ambient cache too; the sphere BVH and the isosurfaces'
// hierarchies for the renderer's life. Frames report what they rebuilt and how long it took.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "penumbra/accel/extinction_sat.h"
#include "penumbra/core/image.h"
#include "penumbra/particles/sphere_bvh.h"
#include "penumbra/render/isosurface_frame.h"
#include "penumbra/render/light_shadows.h"
#include "penumbra/render/prepared_volume.h"
#include "penumbra/render/surface_frame.h"
#include "penumbra/scene/scene.h"
#include "penumbra/shadows/ambient_technique.h"
#include "penumbra/shadows/shadow_casters.h"

namespace penumbra {

struct FrameResult {
  Image image;
  double sat_ms = 0;      // extinction volume + summed area table, when rebuilt this frame
  double ambient_ms = 0;  // ambient-occlusion cache, when rebuilt this frame
  double build_ms = 0;    // shadow structures of the lights rebuilt this frame (and view-dependent ones)
  double render_ms = 0;   // surfaces and ray casting
  double bvh_ms = 0;      // spheres: Embree BVH, when built this frame
  double hits_ms = 0;     // spheres: each pixel's nearest sphere (splatting or Embree rays)
  int issm_rings = -1;    // spheres: the rings t the ISSM used (chosen this frame when automatic)
  std::size_t sphere_pixels = 0;  // pixels showing a sphere
  IsosurfaceFrameStats isosurface;  // isosurfaces: eye pass, shadow passes, counts
  double total_ms = 0;
  std::vector<std::string> rebuilt;  // "sat", "ambient", "bvh", "shadows": what this frame had to rebuild
};

class Renderer {
public:
  explicit Renderer(Scene scene);  // keeps its own copy (volumes are shared, not copied)

  // Renders with the given camera and lights (the scene's by default).
  FrameResult render(const Camera& camera, const std::vector<Light>& lights);
  FrameResult render() { return render(scene_.camera, scene_.lights); }

  // Replaces the first visible volume's transfer function (its shadow transfer function too, unless it
  // has a separate one): the next frame rebuilds the SAT, the ambient cache and every light's shadows.
  void set_transfer_function(const TransferFunction& tf);

  const Scene& scene() const { return scene_; }
  std::size_t shadow_memory_bytes() const;
  std::size_t ambient_memory_bytes() const { return ambient_ ? ambient_->memory_bytes() : 0; }
  std::size_t sat_memory_bytes() const { return sat_ ? sat_->memory_bytes() : 0; }
  std::size_t voxel_count() const;
  std::size_t sphere_count() const { return particles_ ? particles_->size() : 0; }
  std::size_t particle_memory_bytes() const { return particles_ ? particles_->memory_bytes() : 0; }
  std::size_t bvh_memory_bytes() const;
  double prepare_ms() const { return prepare_ms_; }
  // Each isosurface with its min/max hierarchy; each light's shadows of the last frame; the last
  // frame's isosurface eye points (all isosurfaces, in order).
  const std::vector<std::unique_ptr<PreparedIsosurface>>& isosurfaces() const { return isosurfaces_; }
  const std::vector<std::unique_ptr<LightShadows>>& light_shadows() const { return shadows_; }
  const IsoPoints& isosurface_eye_points() const { return isosurface_eye_points_; }

private:
  void prepare_volumes();    // prepared volumes for the current transfer functions
  void prepare_particles();  // one particle set of all the scene's particle objects, casting ones first
  void prepare_isosurfaces();
  void prepare_casters();    // the ShadowCasters of everything that casts
  // Rebuilds the shadows of the lights that changed; true when any was rebuilt.
  bool update_shadows(const std::vector<Light>& lights);

  Scene scene_;
  std::vector<std::unique_ptr<PreparedVolume>> volumes_;  // the visible volumes, one lattice step
  std::vector<std::unique_ptr<MacrocellGrid>> grids_;     // per scene volume (null when not visible)
  std::unique_ptr<ShadowCasters> casters_;
  std::unique_ptr<ShadowCasters> occluders_;              // the ambient technique's kinds
  std::unique_ptr<ExtinctionSat> sat_;
  std::unique_ptr<AmbientTechnique> ambient_;
  std::vector<std::unique_ptr<LightShadows>> shadows_;
  std::vector<Light> built_for_;
  std::shared_ptr<const ParticleSet> particles_;          // every sphere drawn, casting objects first
  std::shared_ptr<const ParticleSet> casting_particles_;  // the casting prefix (particles_ when all cast)
  std::vector<std::uint32_t> particle_offsets_;           // first sphere of each segment of particles_, then the total
  std::vector<std::uint32_t> particle_objects_;           // the scene's particle object of each segment
  std::unique_ptr<SphereBvh> bvh_;                        // over particles_ (Embree rasterizer, rays)
  std::unique_ptr<SphereBvh> casting_bvh_;                // over casting_particles_ when it differs
  bool particles_built_ = false;
  std::vector<std::unique_ptr<PreparedIsosurface>> isosurfaces_;  // sharing one GridTree per volume
  IsoPoints isosurface_eye_points_;  // the last frame's eye passes
  VisibleSurfaces surfaces_;         // the last frame's opaque surfaces (buffers reused)
  bool transfer_function_changed_ = true;  // the SAT and ambient cache are stale
  double prepare_ms_ = 0;
};

}  // namespace penumbra
