// Renders frames of a scene — any mix of volumes, isosurfaces, spheres and planes — and keeps what can
// be reused between frames (paper 001, Algorithm 1). One pipeline for every kind:
//   1. the casters (ShadowCasters: every object that casts, with its acceleration structures) and,
//      per light, a LightShadows (one technique per group of caster kinds);
//   2. the opaque surfaces: each pixel's nearest sphere (splatting or Embree), isosurface point (the
//      eye pass) or plane, shaded under the lights' shadows (surface_frame.h);
//   3. the visible volumes ray cast in front of them, every sample shadowed by the same LightShadows.
//
// Every cached structure has a name (Structures below), and a frame rebuilds only the structures that
// are stale: those an edit invalidated (apply_edit, with the names engine/invalidation.h declares for
// the edited paths), those built for a preview when a full frame is asked for, and those the scene
// newly needs. FrameResult::rebuilt lists them. Edits replace the scene's values in place, so the
// structures that stay valid keep pointing at the same objects.
#pragma once

#include <atomic>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "penumbra/accel/extinction_sat.h"
#include "penumbra/accel/light_cache.h"
#include "penumbra/core/image.h"
#include "penumbra/geometry/sphere_bvh.h"
#include "penumbra/particles/sphere_hits.h"
#include "penumbra/render/isosurface_frame.h"
#include "penumbra/render/light_shadows.h"
#include "penumbra/render/prepared_volume.h"
#include "penumbra/render/surface_frame.h"
#include "penumbra/render/view_refinement.h"
#include "penumbra/render/volume_raycaster.h"
#include "penumbra/scene/scene.h"
#include "penumbra/lighting/ambient_technique.h"
#include "penumbra/lighting/shadow_casters.h"

namespace penumbra {

// A preview follows the user's hand: a reduced image (FrameRequest::preview_divisor), shadow maps at a
// quarter of their resolution or less (sized so the lights rebuild in about 20 ms), the light cache at
// half resolution, and eye and light steps twice as long. Full is the scene as given.
enum class Quality { Preview, Full };
std::string to_string(Quality q);

struct FrameRequest {
  Quality quality = Quality::Full;
  int preview_divisor = 2;   // Preview: the image is rendered at 1/divisor of each side, then enlarged
  bool enlarge_preview = true;  // false: the preview's image, alpha and depth stay at the reduced size
  // Accumulation: sample 0 is the batch frame; sample k > 0 moves every pixel's jitter and the cssm
  // seed (shadows.seed + k), so that the mean of samples 0 … n−1 converges (Engine accumulates).
  std::uint32_t sample = 0;
  // Set from another thread to cancel the frame: render() then throws Cancelled soon after.
  const std::atomic<bool>* cancel = nullptr;
  // Sort-last bricks (distributed/volume_slabs.h): only the volume samples of this slab are composited,
  // and only the opaque surfaces whose visible point lies in it (the others end its samples, over black);
  // unset: all of them.
  std::optional<SampleSlab> slab;
  // With a slab, on one rank of a data-parallel frame: the shadow techniques that combine over bricks
  // build from the slab's own segments and combine with the other ranks' through this
  // (accel/brick_reduction.h); unset: every structure is built from the whole scene.
  BrickReduction* reduction = nullptr;
  // With a reduction, on one rank of a data-parallel frame whose spheres are split by space (a particle
  // scene: no slab; beside a volume: those reaching into the slab): the scene holds this rank's share of
  // the spheres, and the implicit sphere shadow map and the particle ambient occlusion combine over the
  // ranks (accel/brick_reduction.h).
  bool own_spheres = false;
};

struct FrameResult {
  Image image;                // linear RGB over the background, the camera's size
  std::vector<float> alpha;   // per pixel: coverage (1 where an opaque surface shows, else the volumes' opacity)
  std::vector<float> depth;   // per pixel: distance along the primary ray to the first opaque surface or to
                              // where the volumes' accumulated opacity reaches 1/2; infinity: background
  double sat_ms = 0;      // extinction volume + summed area table, when rebuilt this frame
  double ambient_ms = 0;  // ambient-occlusion cache, when rebuilt this frame
  std::size_t ambient_kept = 0;  // what that rebuild kept from the one before (particle_ao: spheres, ambient.reuse)
  double build_ms = 0;    // shadow structures of the lights rebuilt this frame (and view-dependent ones)
  double prepare_ms = 0;  // transfer-function tables, empty space, gradients, min/max, hierarchies, sphere set
  double render_ms = 0;   // surfaces and ray casting
  double bvh_ms = 0;      // spheres: Embree BVH, when built this frame
  double hits_ms = 0;     // spheres: each pixel's nearest sphere (splatting or Embree rays); 0 when the last frame's were kept
  bool surfaces_kept = false;  // the surfaces the camera sees were the last frame's (only lighting changed)
  int issm_rings = -1;    // spheres: the rings t the ISSM used (chosen this frame when automatic)
  std::size_t sphere_pixels = 0;  // pixels showing a sphere
  std::size_t volume_samples = 0;         // volume lattice samples classified (VolumeFrame::samples)
  std::size_t volume_shaded_samples = 0;  // of which shaded
  IsosurfaceFrameStats isosurface;  // isosurfaces: eye pass, shadow passes, counts
  double total_ms = 0;
  Quality quality = Quality::Full;
  std::uint32_t sample = 0;
  // The structures this frame rebuilt (Structures names, e.g. "volumes.0.lut", "lights.1.shadows").
  std::vector<std::string> rebuilt;
  bool refit = false;  // view-dependent shadow work (light pass, automatic ISSM rings) redone for this view
  // Full frames of volumes opened coarser than their pyramid's finest level: the finer box each was drawn
  // from (render/view_refinement.h), what it holds and what this frame loaded and evicted.
  std::vector<RefinementStats> refinement;
};

class Renderer {
public:
  explicit Renderer(Scene scene);  // keeps its own copy (volumes are shared, not copied)

  // Renders with the given camera and lights (the scene's by default). A light that differs from the
  // one its shadows were built for (in what shadows depend on) rebuilds them.
  FrameResult render(const Camera& camera, const std::vector<Light>& lights, const FrameRequest& request = {});
  FrameResult render(const FrameRequest& request = {}) { return render(scene_.camera, scene_.lights, request); }

  // Takes the edited scene (same number of objects of each kind) and marks `stale` (Structures names)
  // for rebuilding on the next frame. The caller (Engine) says what is stale; the renderer keeps every
  // other structure as it is. `lighting_only`: the edit changed nothing but lights, shadows, ambient,
  // light_cache, shading and background, so the surfaces the camera sees stay listed.
  void apply_edit(const Scene& edited, const std::vector<std::string>& stale, bool lighting_only = false);

  // Replaces the first visible volume's transfer function (its shadow transfer function too, unless it
  // has a separate one): the next frame rebuilds what depends on it.
  void set_transfer_function(const TransferFunction& tf);

  // Names of the structures this renderer holds now (built by the last frame).
  std::vector<std::string> structures() const;

  const Scene& scene() const { return scene_; }
  std::size_t shadow_memory_bytes() const;
  std::size_t ambient_memory_bytes() const { return ambient_ ? ambient_->memory_bytes() : 0; }
  std::size_t sat_memory_bytes() const {
    return (sat_ ? sat_->memory_bytes() : 0) + (refined_sat_ ? refined_sat_->memory_bytes() : 0);
  }
  // The packed light cache (a copy of the ambient and cached lights' terms), when the frame uses one.
  std::size_t light_cache_memory_bytes() const { return light_cache_ ? light_cache_->memory_bytes() : 0; }
  std::size_t voxel_count() const;
  std::size_t sphere_count() const { return particles_ ? particles_->size() : 0; }
  std::size_t particle_memory_bytes() const {
    return (particles_ ? particles_->memory_bytes() : 0) + (sphere_order_ ? sphere_order_->memory_bytes() : 0) +
           (casting_sphere_order_ ? casting_sphere_order_->memory_bytes() : 0);
  }
  std::size_t bvh_memory_bytes() const;
  // The visible volumes' own structures: gradients (when stored), min/max grids and empty-cell marks.
  std::size_t volume_structure_memory_bytes() const;
  // What the refined boxes of pyramids (render/view_refinement.h) hold now: voxels and structures.
  std::size_t refined_memory_bytes() const;
  // Per visible volume (in the scene's order): whether its gradients are stored (false: on the fly).
  std::vector<bool> volume_gradients_stored() const;
  double prepare_ms() const { return prepare_ms_; }  // the first frame's preparation
  // Each isosurface with its min/max hierarchy; each light's shadows of the last frame; the last
  // frame's isosurface eye points (all isosurfaces, in order).
  const std::vector<std::unique_ptr<PreparedIsosurface>>& isosurfaces() const { return isosurfaces_; }
  const std::vector<std::unique_ptr<LightShadows>>& light_shadows() const { return shadows_; }
  const IsoPoints& isosurface_eye_points() const { return isosurface_eye_points_; }

private:
  // Rebuilds the stale structures for `quality` (settings_ holds the scene's settings at that quality).
  // `refine_for`: a full frame's camera, for which the pyramids' boxes are chosen (null: none).
  void prepare(Quality quality, const Camera* refine_for, FrameResult& frame);
  void prepare_volumes(FrameResult& frame);
  // A full frame: each pyramid's box for this view, loaded when the one held does not cover it; the
  // eye pass's step made the finest of the boxes' and the volumes'.
  // Returns what the budget leaves after the boxes.
  std::uint64_t refine_volumes(const Camera& camera, FrameResult& frame);
  // A full frame: for each volume opened coarse whose isosurfaces extract points or ray cast, a box of a finer level
  // where the camera looks (the visible volume's box when it has one, else its own, from what `left`
  // leaves), its min/max hierarchy and those isosurfaces prepared over it. An own box that no longer
  // serves gives the new one the voxels both hold: lent when `left` holds the two, else moved.
  void refine_isosurfaces(const Camera& camera, std::uint64_t left, FrameResult& frame);
  // Gives up kept boxes, least recently drawn first, until `room` more bytes fit the refinement budget
  // beside everything refined that is held; what each volume gave up goes to its refinement entry.
  void give_up_kept_boxes(std::uint64_t room, FrameResult& frame);
  // The casters over the opened levels, or with `finer` the refined boxes where the volumes have them,
  // and with `refined_surfaces` the isosurfaces' refined boxes (their light pass extracts from them).
  std::unique_ptr<ShadowCasters> make_casters(std::span<const ShadowCasters::FinerBox> finer, bool refined_surfaces,
                                              const ExtinctionSat* sat) const;
  // The extinction SAT of a full frame whose visible volume is drawn from a refined box: the opened
  // level's cells, those inside the box summed from its voxels (null when there is no SAT or no box).
  std::unique_ptr<ExtinctionSat> refined_extinction_sat(std::span<const ShadowCasters::FinerBox> finer) const;
  // The extinction SAT of volume `v` (with `finer`, a refined box's means in the cells inside it), its
  // cells dividing a pyramid's finest level's box.
  std::unique_ptr<ExtinctionSat> make_extinction_sat(const VolumeObject& v, const Volume* finer) const;
  // A full frame's casters: refined_casters_ built (or dropped) for the boxes held; true when changed.
  // The extinction SAT is refined with them ("sat.refined" in `frame`'s rebuilt list, its time in sat_ms).
  bool update_refined_casters(FrameResult& frame);
  // The ambient technique and every light's shadows, to be built again (the casters changed).
  void light_structures_stale();
  // The casters this frame's light structures are built from: a full frame's refined ones where held.
  const ShadowCasters& frame_casters() const {
    return building_ == Quality::Full && refined_casters_ ? *refined_casters_ : *casters_;
  }
  void prepare_particles(FrameResult& frame);
  void prepare_isosurfaces(FrameResult& frame);
  void update_shadows(const std::vector<Light>& lights, Quality quality, std::uint32_t sample, const ShadowBrick* brick,
                      FrameResult& frame);
  void update_light_cache();
  // On a brick of a frame split by slabs whose bricks hold their own isosurface cells, a rank's surface
  // points are its brick's nearest, hidden ones included: the receivers the view-dependent shadow fits
  // take are this brick's points of the pixels whose nearest point over the bricks (a minimum over the
  // rectangle holding every brick's surface pixels) lies in its slab, so that the bricks' receivers
  // together are one process's.
  std::vector<SurfacePoint> receivers_shown(const ShadowBrick& brick, const Camera& camera, const VisibleSurfaces& surfaces) const;
  // A brick's frame holds the opaque surfaces whose visible point lies in its slab: elsewhere the
  // surface only ends the brick's samples (another brick shows it), its colour the background's and
  // its opacity 0.
  void drop_surfaces_outside(const SampleSlab& slab, const Camera& camera, std::span<const float> distance, Image& opaque,
                             std::span<float> alpha) const;
  bool stale(const std::string& name) const { return stale_.count(name) != 0; }
  void rebuilt(const std::string& name, Quality quality, FrameResult& frame);
  void mark_all_stale();
  FrameResult render_at(const Camera& camera, const std::vector<Light>& lights, const FrameRequest& request);

  Scene scene_;
  Scene settings_;  // scene_ with the settings of the quality being built (preview: coarser)
  std::set<std::string> stale_;                // structures to rebuild before the next frame
  std::map<std::string, Quality> built_at_;    // the quality each structure was built at
  Quality building_ = Quality::Full;           // the quality of the frame being prepared
  std::vector<std::unique_ptr<PreparedVolume>> volumes_;  // the visible volumes, one lattice step
  std::vector<int> volume_index_;                         // scene volume of each prepared volume
  std::vector<std::unique_ptr<RefinedVolume>> refined_;   // per prepared volume: the box full frames draw (or none)
  std::vector<std::optional<FailedRefinement>> refine_failures_;  // per prepared volume: the last box whose read failed
  // Boxes drawn before and set aside, kept while the budget holds them with the boxes drawn, so that a
  // view that comes back reads nothing; the least recently drawn is given up first.
  struct KeptBox {
    std::unique_ptr<RefinedVolume> box;
    std::uint64_t drawn = 0;  // the refine_volumes call that drew it last
  };
  std::vector<std::vector<KeptBox>> kept_;  // per prepared volume
  std::uint64_t refine_calls_ = 0;
  // A refined box of a volume opened coarse for its isosurfaces' eye pass: the box's voxels (its own, or
  // the visible volume's refined box), their hierarchy and each of the volume's isosurfaces over it.
  struct RefinedSurfaces {
    LevelBox box;
    std::string key;  // PyramidSource::key
    std::shared_ptr<const Volume> voxels;
    // voxels when read for the isosurfaces, which a box that moves takes over (null: the refined
    // volume's, counted there)
    std::shared_ptr<Volume> own;
    std::shared_ptr<const GridTree> tree;
    std::map<std::size_t, std::unique_ptr<PreparedIsosurface>> surfaces;  // by scene isosurface
    std::uint64_t held_bytes() const;  // what the budget counts: its own box's voxels and hierarchy
  };
  std::map<std::size_t, RefinedSurfaces> refined_surfaces_;            // by scene volume
  std::map<std::size_t, std::optional<FailedRefinement>> surface_refine_failures_;  // by scene volume: the last box whose read failed
  std::unique_ptr<ShadowCasters> casters_;
  // casters_ with the refined boxes (full frames' light structures; null when no box is held or casters_
  // changed since; dropped with a box given up); refined_changed_: a box was loaded since they were built
  std::unique_ptr<ShadowCasters> refined_casters_;
  std::unique_ptr<ExtinctionSat> refined_sat_;  // the SAT refined_casters_ carry when the visible volume has a box
  bool refined_changed_ = false;
  std::unique_ptr<ShadowCasters> occluders_;              // the ambient technique's kinds
  std::unique_ptr<ExtinctionSat> sat_;
  const ShadowBrick* frame_brick_ = nullptr;  // during prepare(): the frame's brick (its SAT summed over bricks)
  std::optional<SampleSlab> sat_slab_;         // the slab the SAT was summed for (none: the whole volume's)
  std::unique_ptr<AmbientTechnique> ambient_;
  AmbientSettings ambient_settings_;  // what ambient_ was built with
  std::vector<std::unique_ptr<LightShadows>> shadows_;
  // Paper 001's light cache texture: the ambient term and the sat_cone lights' terms packed per cell
  // (null when fewer than two terms would share it); each light's slot in it (−1: asked separately);
  // which sources were rebuilt since they were packed.
  std::unique_ptr<LightCache> light_cache_;
  std::vector<int> light_slot_;
  bool repack_ambient_ = true;
  std::vector<bool> repack_light_;
  std::vector<Light> built_for_;
  std::vector<std::uint64_t> seed_of_;                    // the cssm seed each light's shadows were built with
  std::vector<double> full_shadow_ms_of_;                 // each light's last full-quality build time (0: none yet)
  double full_shadow_ms_ = 0;                             // their sum: sizes the preview maps
  std::shared_ptr<ParticleSet> particles_;                // every sphere drawn, casting objects first (own copy)
  std::shared_ptr<ParticleSet> casting_particles_;        // the casting prefix (particles_ when all cast)
  std::vector<std::uint32_t> particle_offsets_;           // first sphere of each segment of particles_, then the total
  std::vector<std::uint32_t> particle_objects_;           // the scene's particle object of each segment
  std::unique_ptr<SphereOrder> sphere_order_;             // particles_ in spatial order (the splats)
  std::unique_ptr<SphereOrder> casting_sphere_order_;     // the same of casting_particles_ when it differs
  std::unique_ptr<SphereBvh> bvh_;                        // over particles_ (Embree rasterizer, rays)
  std::unique_ptr<SphereBvh> casting_bvh_;                // over casting_particles_ when it differs
  std::map<std::size_t, std::shared_ptr<const GridTree>> trees_;  // min/max hierarchy per scene volume
  std::vector<std::unique_ptr<PreparedIsosurface>> isosurfaces_;  // sharing one GridTree per volume
  IsoPoints isosurface_eye_points_;  // the last frame's eye passes
  VisibleSurfaces surfaces_;         // the last frame's opaque surfaces (buffers reused)
  // The camera surfaces_ were listed for, while nothing they list has changed since (a frame whose
  // light alone moved shades them again without listing them): scenes of spheres and planes without
  // slices; isosurface points and slices' colours are listed anew in every frame.
  std::optional<Camera> surfaces_for_;
  // Each pixel's nearest sphere, kept while the camera, the spheres and the rasterizer stay: a light,
  // shadow, colour or transfer-function edit does not move what the eye sees.
  SphereHits hits_;
  std::optional<std::pair<Camera, SphereRasterizer>> hits_for_;
  bool first_frame_ = true;
  double prepare_ms_ = 0;
};

// Whether two lights cast the same shadows (colour and intensity do not change them).
bool same_shadow_geometry(const Light& a, const Light& b);

}  // namespace penumbra
