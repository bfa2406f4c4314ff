#include "penumbra/render/renderer.h"

#include <algorithm>
#include <cmath>

#include "penumbra/core/cancel.h"
#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/particles/sphere_hits.h"
#include "penumbra/render/frame_settings.h"
#include "penumbra/render/sphere_clipping.h"
#include "penumbra/render/surface_frame.h"
#include "penumbra/render/volume_raycaster.h"
#include "penumbra/registry/technique_catalog.h"
#include "penumbra/shadows/sat_cone.h"
#include "penumbra/shadows/volume_ambient_occlusion.h"
#include "penumbra/lighting/shared_params.h"
#include "penumbra/registry/registry.h"

namespace penumbra {
namespace {

std::string indexed(const char* kind, std::size_t i, const char* what) {
  return std::string(kind) + "." + std::to_string(i) + "." + what;
}

// The eye lattice step shared by the visible volumes: the finest of their steps.
float shared_step(const Scene& s) {
  float step = kInfinity;
  for (const auto& v : s.volumes)
    if (v.visible) step = std::min(step, v.step_world());
  return step;
}

// The image (and alpha, depth) rendered at 1/divisor of each side, enlarged to width × height by
// repeating each pixel.
template <class T>
std::vector<T> enlarged(const std::vector<T>& small, int sw, int sh, int width, int height) {
  std::vector<T> out(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
  for (int y = 0; y < height; ++y) {
    const int sy = std::min(sh - 1, y * sh / height);
    for (int x = 0; x < width; ++x) {
      const int sx = std::min(sw - 1, x * sw / width);
      out[static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x)] =
          small[static_cast<std::size_t>(sy) * static_cast<std::size_t>(sw) + static_cast<std::size_t>(sx)];
    }
  }
  return out;
}

}  // namespace

std::string to_string(Quality q) { return q == Quality::Preview ? "preview" : "full"; }

bool same_shadow_geometry(const Light& a, const Light& b) {
  return a.type == b.type && a.position == b.position && a.direction == b.direction && a.angle_deg == b.angle_deg &&
         a.softness == b.softness;
}

Renderer::Renderer(Scene scene) : scene_(std::move(scene)) { mark_all_stale(); }

void Renderer::mark_all_stale() {
  for (std::size_t i = 0; i < scene_.volumes.size(); ++i)
    for (const char* what : {"gradients", "minmax", "lut", "empty_space", "hierarchy"}) stale_.insert(indexed("volumes", i, what));
  for (std::size_t i = 0; i < scene_.isosurfaces.size(); ++i)
    for (const char* what : {"surface", "mesh"}) stale_.insert(indexed("isosurfaces", i, what));
  for (const char* what : {"spheres", "spheres.colors", "spheres.clip", "bvh", "casters", "sat", "ambient"}) stale_.insert(what);
  for (std::size_t i = 0; i < scene_.lights.size(); ++i) stale_.insert(indexed("lights", i, "shadows"));
}

void Renderer::apply_edit(const Scene& edited, const std::vector<std::string>& stale, bool lighting_only) {
  if (edited.volumes.size() != scene_.volumes.size() || edited.particles.size() != scene_.particles.size() ||
      edited.isosurfaces.size() != scene_.isosurfaces.size() || edited.planes.size() != scene_.planes.size())
    throw Error("Renderer::apply_edit: the edit changes the number of objects (make a new renderer)");
  // in place, so that what stays valid keeps pointing at the same objects
  for (std::size_t i = 0; i < edited.volumes.size(); ++i) scene_.volumes[i] = edited.volumes[i];
  for (std::size_t i = 0; i < edited.particles.size(); ++i) scene_.particles[i] = edited.particles[i];
  for (std::size_t i = 0; i < edited.isosurfaces.size(); ++i) scene_.isosurfaces[i] = edited.isosurfaces[i];
  for (std::size_t i = 0; i < edited.planes.size(); ++i) scene_.planes[i] = edited.planes[i];
  scene_.clip_planes = edited.clip_planes;
  scene_.first_slice = edited.first_slice;
  scene_.camera = edited.camera;
  scene_.lights = edited.lights;
  scene_.sphere_rasterizer = edited.sphere_rasterizer;
  scene_.shadows = edited.shadows;
  scene_.ambient = edited.ambient;
  scene_.light_cache = edited.light_cache;
  scene_.shading = edited.shading;
  scene_.background = edited.background;
  scene_.unread_keys = edited.unread_keys;
  scene_.time = edited.time;
  stale_.insert(stale.begin(), stale.end());
  if (!lighting_only) surfaces_for_.reset();
}

void Renderer::set_transfer_function(const TransferFunction& tf) {
  const VolumeObject* visible = scene_.visible_volume();
  if (!visible) throw Error("set_transfer_function: the scene has no visible volume");
  Scene edited = scene_;
  const auto i = static_cast<std::size_t>(visible - scene_.volumes.data());
  edited.volumes[i].transfer_function = tf;
  std::vector<std::string> stale{indexed("volumes", i, "lut"), indexed("volumes", i, "empty_space"), "casters", "sat", "ambient"};
  for (std::size_t l = 0; l < scene_.lights.size(); ++l) stale.push_back(indexed("lights", l, "shadows"));
  apply_edit(edited, stale);
}

void Renderer::rebuilt(const std::string& name, Quality quality, FrameResult& frame) {
  stale_.erase(name);
  built_at_[name] = quality;
  if (std::find(frame.rebuilt.begin(), frame.rebuilt.end(), name) == frame.rebuilt.end()) frame.rebuilt.push_back(name);
}

std::vector<std::string> Renderer::structures() const {
  std::vector<std::string> names;
  for (std::size_t k = 0; k < volumes_.size(); ++k) {
    const auto i = static_cast<std::size_t>(volume_index_[k]);
    for (const char* what : {"gradients", "minmax", "lut", "empty_space"}) names.push_back(indexed("volumes", i, what));
    if (k < refined_.size() && refined_[k]) names.push_back(indexed("volumes", i, "refined"));
  }
  for (const auto& [i, tree] : trees_) names.push_back(indexed("volumes", i, "hierarchy"));
  for (const auto& [i, r] : refined_surfaces_) names.push_back(indexed("volumes", i, "refined_hierarchy"));
  for (std::size_t i = 0; i < isosurfaces_.size(); ++i) {
    names.push_back(indexed("isosurfaces", i, "surface"));
    if (isosurfaces_[i]->mesh) names.push_back(indexed("isosurfaces", i, "mesh"));
  }
  if (particles_) {
    names.push_back("spheres");
    names.push_back("spheres.colors");
    names.push_back("spheres.clip");
  }
  if (bvh_) names.push_back("bvh");
  if (casters_) names.push_back("casters");
  if (refined_casters_) names.push_back("casters.refined");
  if (sat_) names.push_back("sat");
  if (refined_sat_) names.push_back("sat.refined");
  if (ambient_) names.push_back("ambient");
  for (std::size_t i = 0; i < shadows_.size(); ++i)
    if (!shadow_assignments(scene_).empty()) names.push_back(indexed("lights", i, "shadows"));
  std::sort(names.begin(), names.end());
  return names;
}

void Renderer::prepare_volumes(FrameResult& frame) {
  const float step = shared_step(scene_);
  if (volumes_.empty() && !scene_.volumes.empty()) {  // first frame: one prepared volume per visible one
    for (std::size_t i = 0; i < scene_.volumes.size(); ++i) {
      if (!scene_.volumes[i].visible) continue;
      volumes_.push_back(std::make_unique<PreparedVolume>(scene_.volumes[i], step));
      volume_index_.push_back(static_cast<int>(i));
      for (const char* what : {"gradients", "minmax", "empty_space"}) rebuilt(indexed("volumes", i, what), Quality::Full, frame);
      rebuilt(indexed("volumes", i, "lut"), Quality::Full, frame);
    }
  }
  for (std::size_t k = 0; k < volumes_.size(); ++k) {
    const auto i = static_cast<std::size_t>(volume_index_[k]);
    PreparedVolume& pv = *volumes_[k];
    pv.object = &scene_.volumes[i];
    pv.clip = &scene_.clip_planes_for(scene_.volumes[i].clip);
    if (stale(indexed("volumes", i, "gradients"))) {
      pv.update_gradients();
      rebuilt(indexed("volumes", i, "gradients"), Quality::Full, frame);
    }
    if (stale(indexed("volumes", i, "minmax"))) {
      pv.update_grid();
      rebuilt(indexed("volumes", i, "minmax"), Quality::Full, frame);
      stale_.insert(indexed("volumes", i, "empty_space"));  // read from the grid
      stale_.insert("casters");                              // they point at it
    }
    if (stale(indexed("volumes", i, "lut")) || pv.full_step != step) {
      pv.update_lut(step);
      rebuilt(indexed("volumes", i, "lut"), Quality::Full, frame);
    }
    pv.use(building_ == Quality::Preview);
    if (stale(indexed("volumes", i, "empty_space"))) {
      pv.update_empty();
      rebuilt(indexed("volumes", i, "empty_space"), Quality::Full, frame);
    }
  }
  // hidden volumes have nothing prepared
  for (std::size_t i = 0; i < scene_.volumes.size(); ++i)
    if (!scene_.volumes[i].visible)
      for (const char* what : {"gradients", "minmax", "lut", "empty_space"}) stale_.erase(indexed("volumes", i, what));
}

void Renderer::prepare_particles(FrameResult& frame) {
  if (!scene_.has_particles()) {
    for (const char* what : {"spheres", "spheres.colors", "spheres.clip", "bvh"}) stale_.erase(what);
    return;
  }
  // casting objects first, so that the casting spheres are a prefix with the same indices; hidden
  // sets (particles[].visible) are left out
  std::vector<std::uint32_t> order;
  for (int pass = 0; pass < 2; ++pass)
    for (std::size_t i = 0; i < scene_.particles.size(); ++i)
      if (scene_.particles[i].visible && scene_.particles[i].casts_shadows == (pass == 0)) order.push_back(static_cast<std::uint32_t>(i));
  std::unique_ptr<SphereOrder> carried, carried_casting;  // the last set's orders, for a new set of its size
  if (stale("spheres") || !particles_) {
    std::size_t casting = 0;
    for (const auto& p : scene_.particles)
      if (p.visible && p.casts_shadows) casting += p.set->size();
    auto merged = std::make_shared<ParticleSet>();  // one set, so that every sphere shadows every other
    for (std::uint32_t i : order) {
      const ParticleSet& s = *scene_.particles[i].set;
      merged->spheres.insert(merged->spheres.end(), s.spheres.begin(), s.spheres.end());
      merged->colors.insert(merged->colors.end(), s.colors.begin(), s.colors.end());
    }
    particles_ = std::move(merged);
    // the same objects with as many spheres (a trajectory's next frame): the last order is carried over
    if (sphere_order_ && sphere_order_->size() == particles_->size() && particle_objects_ == order) {
      carried = std::move(sphere_order_);
      carried_casting = std::move(casting_sphere_order_);
    }
    particle_offsets_.clear();
    particle_objects_.clear();
    std::uint32_t offset = 0;
    for (std::uint32_t i : order) {
      particle_offsets_.push_back(offset);
      particle_objects_.push_back(i);
      offset += static_cast<std::uint32_t>(scene_.particles[i].set->size());
    }
    particle_offsets_.push_back(offset);
    casting_particles_.reset();
    sphere_order_.reset();
    casting_sphere_order_.reset();
    if (casting == particles_->size()) {
      casting_particles_ = particles_;
    } else if (casting > 0) {
      auto prefix = std::make_shared<ParticleSet>();
      prefix->spheres.assign(particles_->spheres.begin(), particles_->spheres.begin() + static_cast<std::ptrdiff_t>(casting));
      prefix->colors.assign(particles_->colors.begin(), particles_->colors.begin() + static_cast<std::ptrdiff_t>(casting));
      casting_particles_ = std::move(prefix);
    }
    rebuilt("spheres", Quality::Full, frame);
    rebuilt("spheres.colors", Quality::Full, frame);
    stale_.insert("spheres.clip");  // the new set is not marked yet
    hits_for_.reset();
    stale_.insert("bvh");      // it points at the set
    stale_.insert("casters");  // so do they
  } else if (stale("spheres.colors")) {  // new colours, same spheres: in place
    for (std::size_t s = 0; s < order.size(); ++s) {
      const ParticleSet& set = *scene_.particles[order[s]].set;
      std::copy(set.colors.begin(), set.colors.end(), particles_->colors.begin() + particle_offsets_[s]);
      if (casting_particles_ && casting_particles_ != particles_ && particle_offsets_[s] < casting_particles_->size())
        std::copy(set.colors.begin(), set.colors.end(), casting_particles_->colors.begin() + particle_offsets_[s]);
    }
    rebuilt("spheres.colors", Quality::Full, frame);
    surfaces_for_.reset();
  }
  if (stale("spheres.clip")) {  // which spheres the clip planes cut or remove
    std::vector<bool> clipped;
    for (std::uint32_t i : order) clipped.push_back(scene_.particles[i].clip);
    clip_spheres(*particles_, scene_.clip_planes, particle_offsets_, clipped);
    if (casting_particles_ && casting_particles_ != particles_) {
      casting_particles_->clip_planes = particles_->clip_planes;
      casting_particles_->clip_state.assign(particles_->clip_state.begin(),
                                            particles_->clip_state.begin() + static_cast<std::ptrdiff_t>(std::min(particles_->clip_state.size(), casting_particles_->size())));
    }
    rebuilt("spheres.clip", Quality::Full, frame);
    hits_for_.reset();
    stale_.insert("bvh");      // cut spheres are intersected apart
    stale_.insert("casters");
  }
  if (!needs_sphere_order(scene_)) {
    sphere_order_.reset();
    casting_sphere_order_.reset();
  } else if (!sphere_order_) {  // the splats walk the spheres in this order (of the set, so clipping keeps it)
    if (carried) carry_order(*carried, *particles_);
    sphere_order_ = carried ? std::move(carried) : std::make_unique<SphereOrder>(spatial_order(*particles_));
    if (casting_particles_ && casting_particles_ != particles_) {
      if (carried_casting && carried_casting->size() == casting_particles_->size()) {
        carry_order(*carried_casting, *casting_particles_);
        casting_sphere_order_ = std::move(carried_casting);
      } else {
        casting_sphere_order_ = std::make_unique<SphereOrder>(prefix_order(*sphere_order_, casting_particles_->size()));
      }
    }
    stale_.insert("casters");  // they take the order
  }
  const bool wants_bvh = needs_sphere_bvh(scene_);
  if (wants_bvh && (stale("bvh") || !bvh_)) {
    Timer t;
    bvh_ = std::make_unique<SphereBvh>(*particles_);
    casting_bvh_.reset();
    if (casting_particles_ && casting_particles_ != particles_) casting_bvh_ = std::make_unique<SphereBvh>(*casting_particles_);
    frame.bvh_ms = t.elapsed_ms();
    rebuilt("bvh", Quality::Full, frame);
    stale_.insert("casters");  // the casters take the BVH
  } else if (!wants_bvh) {
    if (bvh_ && stale("bvh")) stale_.insert("casters");
    bvh_.reset();
    casting_bvh_.reset();
    stale_.erase("bvh");
  }
}

void Renderer::prepare_isosurfaces(FrameResult& frame) {
  for (std::size_t i = 0; i < scene_.volumes.size(); ++i) {
    const std::string name = indexed("volumes", i, "hierarchy");
    bool used = false;
    for (const auto& o : scene_.isosurfaces) used = used || o.volume == i;
    if (!used) {
      trees_.erase(i);
      stale_.erase(name);
      continue;
    }
    if (stale(name) || !trees_.count(i)) {
      trees_[i] = std::make_shared<const GridTree>(*scene_.volumes[i].volume);
      rebuilt(name, Quality::Full, frame);
      for (std::size_t s = 0; s < scene_.isosurfaces.size(); ++s)
        if (scene_.isosurfaces[s].volume == i) stale_.insert(indexed("isosurfaces", s, "surface"));
    }
  }
  isosurfaces_.resize(scene_.isosurfaces.size());
  for (std::size_t s = 0; s < scene_.isosurfaces.size(); ++s) {
    const IsosurfaceObject& o = scene_.isosurfaces[s];
    if (stale(indexed("isosurfaces", s, "surface")) || !isosurfaces_[s]) {
      isosurfaces_[s] = std::make_unique<PreparedIsosurface>(trees_.at(o.volume), o);
      rebuilt(indexed("isosurfaces", s, "surface"), Quality::Full, frame);
      stale_.insert("casters");  // they point at the ray caster
      stale_.insert(indexed("isosurfaces", s, "mesh"));
    }
    isosurfaces_[s]->object = &o;
    if (stale(indexed("isosurfaces", s, "mesh"))) {
      isosurfaces_[s]->mesh.reset();  // the eye pass extracts it again when the method is mesh
      stale_.erase(indexed("isosurfaces", s, "mesh"));
    }
  }
}

std::unique_ptr<ShadowCasters> Renderer::make_casters(std::span<const ShadowCasters::FinerBox> finer, bool refined_surfaces,
                                                      const ExtinctionSat* sat) const {
  std::vector<const MacrocellGrid*> grids(scene_.volumes.size(), nullptr);
  for (std::size_t k = 0; k < volumes_.size(); ++k) grids[static_cast<std::size_t>(volume_index_[k])] = &volumes_[k]->grid;
  auto casters = std::make_unique<ShadowCasters>(settings_, grids, finer);
  // spheres split over the ranks (FrameRequest::own_spheres): every rank fits its light structures to
  // the box of all of them, though it may hold no casting sphere
  const bool split = frame_brick_ && frame_brick_->own_spheres && (casting_kinds(scene_) & kind_bit(ObjectKind::Spheres));
  if (casting_particles_ || split) {
    static const ParticleSet kNoSpheres;
    const SphereBvh* bvh = casting_particles_ == particles_ ? bvh_.get() : casting_bvh_.get();
    Box3 bounds = casting_particles_ ? casting_particles_->bounds() : Box3{};
    if (split) bounds = combined_bounds(bounds, *frame_brick_->reduction);
    const SphereOrder* order = casting_particles_ == particles_ ? sphere_order_.get() : casting_sphere_order_.get();
    casters->set_spheres(CastingSpheres{casting_particles_ ? casting_particles_.get() : &kNoSpheres, bvh, bounds, order});
  }
  for (std::size_t i = 0; i < isosurfaces_.size(); ++i) {
    if (!scene_.isosurfaces[i].casts_shadows) continue;
    CastingIsosurface::Finer finer_surface;  // the light pass and shadow rays meet it inside a refined box
    const auto refined = refined_surfaces ? refined_surfaces_.find(scene_.isosurfaces[i].volume) : refined_surfaces_.end();
    if (refined != refined_surfaces_.end() && refined->second.surfaces.count(i))
      finer_surface = {&refined->second.surfaces.at(i)->raycaster, refined->second.tree.get()};
    casters->add_isosurface(isosurfaces_[i]->raycaster, *isosurfaces_[i]->tree, static_cast<std::uint32_t>(i),
                            scene_.clip_planes_for(scene_.isosurfaces[i].clip), finer_surface);
  }
  if (sat) casters->attach_extinction_sat(sat);
  return casters;
}

void Renderer::light_structures_stale() {
  stale_.insert("ambient");
  for (std::size_t l = 0; l < scene_.lights.size(); ++l) stale_.insert(indexed("lights", l, "shadows"));
}

bool Renderer::update_refined_casters(FrameResult& frame) {
  std::vector<ShadowCasters::FinerBox> finer(scene_.volumes.size());
  bool any = false;
  for (std::size_t k = 0; k < refined_.size() && k < volumes_.size(); ++k)
    if (refined_[k]) {
      finer[static_cast<std::size_t>(volume_index_[k])] = {&refined_[k]->object(), &refined_[k]->prepared().grid};
      any = true;
    }
  for (const auto& entry : refined_surfaces_) any = any || !entry.second.surfaces.empty();
  if (!any) {
    const bool had = refined_casters_ != nullptr;
    refined_casters_.reset();
    refined_sat_.reset();
    return had;
  }
  if (refined_casters_ && !refined_changed_) return false;
  Timer t;
  refined_sat_ = refined_extinction_sat(finer);
  if (refined_sat_) {
    frame.sat_ms += t.elapsed_ms();
    rebuilt("sat.refined", Quality::Full, frame);
  }
  refined_casters_ = make_casters(finer, true, refined_sat_ ? refined_sat_.get() : sat_.get());
  refined_changed_ = false;
  return true;
}

std::unique_ptr<ExtinctionSat> Renderer::refined_extinction_sat(std::span<const ShadowCasters::FinerBox> finer) const {
  const VolumeObject* v = sat_ ? scene_.visible_volume() : nullptr;
  if (!v || frame_brick_) return nullptr;
  const auto i = static_cast<std::size_t>(v - scene_.volumes.data());
  if (i >= finer.size() || !finer[i].object) return nullptr;
  return make_extinction_sat(*v, finer[i].object->volume.get());
}

std::unique_ptr<ExtinctionSat> Renderer::make_extinction_sat(const VolumeObject& v, const Volume* finer) const {
  // a pyramid's levels share the cells of its finest level (a distributed brick keeps its own); the
  // casting spheres enter the table too (approximate ambient occlusion and cone shadows by spheres)
  std::optional<Box3> cells;
  if (v.pyramid && !v.volume->is_window() && !frame_brick_) cells = v.pyramid->bounds(*v.volume);
  return std::make_unique<ExtinctionSat>(*v.volume, v.shadow_tf(), v.compositing, v.reference_step(), settings_.light_cache.resolution,
                                         needs_extinction_colour(scene_), casting_particles_.get(), frame_brick_,
                                         &scene_.clip_planes_for(v.clip), finer, cells ? &*cells : nullptr);
}

std::size_t Renderer::voxel_count() const {
  std::size_t n = 0;
  for (const auto& v : volumes_) n += v->volume->voxel_count();
  if (n == 0 && !isosurfaces_.empty()) n = isosurfaces_.front()->tree->volume().voxel_count();
  return n;
}

std::size_t Renderer::volume_structure_memory_bytes() const {
  std::size_t bytes = 0;
  for (const auto& pv : volumes_) bytes += pv->memory_bytes();
  return bytes;
}

std::size_t Renderer::refined_memory_bytes() const {
  std::size_t bytes = 0;
  for (const auto& r : refined_)
    if (r) bytes += r->held_bytes();
  for (const auto& kept : kept_)
    for (const KeptBox& k : kept) bytes += k.box->held_bytes();
  for (const auto& [i, r] : refined_surfaces_) bytes += r.held_bytes();
  return bytes;
}

std::uint64_t Renderer::RefinedSurfaces::held_bytes() const {
  // over a visible volume's box the hierarchy is, like the opened level's, outside the budget
  return own ? voxels->memory_bytes() + tree->memory_bytes() : 0;
}

namespace {

// The frame's refinement entry of a scene volume, added when it has none yet.
RefinementStats& refinement_entry(FrameResult& frame, std::size_t volume) {
  for (RefinementStats& s : frame.refinement)
    if (s.volume == volume) return s;
  frame.refinement.emplace_back().volume = volume;
  return frame.refinement.back();
}

}  // namespace

void Renderer::give_up_kept_boxes(std::uint64_t room, FrameResult& frame) {
  while (refined_memory_bytes() + room > scene_.refinement_bytes) {
    std::size_t vk = kept_.size(), at = 0;  // the least recently drawn
    for (std::size_t k = 0; k < kept_.size(); ++k)
      for (std::size_t n = 0; n < kept_[k].size(); ++n)
        if (vk == kept_.size() || kept_[k][n].drawn < kept_[vk][at].drawn) vk = k, at = n;
    if (vk == kept_.size()) return;
    refinement_entry(frame, static_cast<std::size_t>(volume_index_[vk])).evicted_bytes += kept_[vk][at].box->held_bytes();
    kept_[vk].erase(kept_[vk].begin() + static_cast<std::ptrdiff_t>(at));
  }
}

std::uint64_t Renderer::refine_volumes(const Camera& camera, FrameResult& frame) {
  refined_.resize(volumes_.size());
  refine_failures_.resize(volumes_.size());
  kept_.resize(volumes_.size());
  ++refine_calls_;
  // one entry per refined volume at most: the references to them below stay valid while boxes given up
  // for one volume add entries for others
  frame.refinement.reserve(frame.refinement.size() + volumes_.size());
  std::uint64_t left = scene_.refinement_bytes;  // what the boxes drawn leave
  float step = volumes_.empty() ? 0.0f : volumes_.front()->full_step;
  for (std::size_t k = 0; k < volumes_.size(); ++k) {
    const auto i = static_cast<std::size_t>(volume_index_[k]);
    const VolumeObject& o = scene_.volumes[i];
    std::unique_ptr<RefinedVolume>& held = refined_[k];
    std::vector<KeptBox>& kept = kept_[k];
    RefinementStats& stats = refinement_entry(frame, i);
    // the box drawn is drawn no more: what casts from it goes now (a read that fails or is cancelled
    // next leaves no light structure pointing into it; a preview then builds them from the opened level)
    auto undraw = [&] {
      refined_casters_.reset();
      refined_sat_.reset();
      light_structures_stale();
    };
    auto set_aside = [&] {  // kept, most recently drawn, for a view that comes back
      if (!held) return;
      undraw();
      kept.insert(kept.begin(), KeptBox{std::move(held), refine_calls_ - 1});
    };
    // boxes of another store (the file was edited) or of a volume no longer refined are given up
    const PyramidSource* pyramid_of = o.pyramid && !o.volume->is_window() ? o.pyramid.get() : nullptr;
    if (held && (!pyramid_of || !held->reads(*pyramid_of))) {
      undraw();
      stats.evicted_bytes += held->held_bytes();
      held.reset();
    }
    std::erase_if(kept, [&](const KeptBox& b) {
      if (pyramid_of && b.box->reads(*pyramid_of)) return false;
      stats.evicted_bytes += b.box->held_bytes();
      return true;
    });
    if (!pyramid_of) continue;
    const PyramidSource& pyramid = *pyramid_of;
    stats.opened_level = stats.level = pyramid.opened;
    // one volume may be refined in its near part only (the ray caster draws the rest from the opened
    // level); beside others the box replaces the volume in the eye pass, so it must hold all it shows
    const std::optional<RefinementChoice> choice = choose_refinement(camera, pyramid, pyramid.bounds(*o.volume), left,
                                                                     volumes_[k]->gradients_stored(), volumes_.size() == 1);
    auto serves = [&](const RefinedVolume& box) { return box_serves(box.box(), box.held_bytes(), pyramid, choice, left); };
    const bool keep = held && serves(*held);
    const auto again = std::find_if(kept.begin(), kept.end(), [&](const KeptBox& b) { return serves(*b.box); });
    std::optional<FailedRefinement>& failed = refine_failures_[k];
    bool follow = keep;
    if (keep) {
      // the box drawn serves this view too: nothing to read
    } else if (again != kept.end()) {
      // a box drawn before serves again: drawn from memory, the one drawn until now set aside
      std::unique_ptr<RefinedVolume> back = std::move(again->box);
      kept.erase(again);
      set_aside();
      held = std::move(back);
      refined_changed_ = true;
      follow = true;
      rebuilt(indexed("volumes", i, "refined"), Quality::Full, frame);
    } else if (!choice || (failed && failed->covers(pyramid, *choice))) {
      // the opened level is fine enough here (or nothing is in view), or the box could not be read
      // before and is not read again for views inside it: the opened level draws them
      set_aside();
      if (choice) stats.error = failed->error;
    } else {
      // the box drawn is set aside; boxes kept give way, least recently drawn first, until the new one
      // fits the budget; the most recent one of the same level that overlaps it lends its voxels there,
      // or, when the budget cannot hold it beside the new one, moves: its memory becomes the new box's,
      // the voxels both hold moved in place, and only what it did not hold is read
      set_aside();
      std::unique_ptr<RefinedVolume> moving;
      auto overlapping = [&](const KeptBox& b) { return b.box->box().level == choice->box.level && overlaps(b.box->box(), choice->box); };
      const auto lender = std::find_if(kept.begin(), kept.end(), overlapping);
      if (lender != kept.end()) {
        std::uint64_t all_kept = 0;
        for (const auto& boxes : kept_)
          for (const KeptBox& b : boxes) all_kept += b.box->held_bytes();
        const std::uint64_t others = refined_memory_bytes() - all_kept;  // boxes drawn for other volumes, surfaces' boxes
        if (others + refined_bytes(choice->box, o.volume->type(), choice->stored_gradients) + lender->box->held_bytes() > scene_.refinement_bytes) {
          moving = std::move(lender->box);
          kept.erase(lender);
          // an isosurface hierarchy over it lets its voxels go (refine_isosurfaces makes one over the new box)
          if (std::erase_if(refined_surfaces_, [&](const auto& r) { return r.second.voxels == moving->object().volume; }))
            refined_changed_ = true;
        }
      }
      give_up_kept_boxes(refined_bytes(choice->box, o.volume->type(), choice->stored_gradients), frame);
      const auto still = moving ? kept.end() : std::find_if(kept.begin(), kept.end(), overlapping);  // (if not given up)
      const RefinedVolume* lends = still == kept.end() ? nullptr : still->box.get();
      const std::uint64_t moving_bytes = moving ? moving->held_bytes() : 0;
      const bool read = read_refinement_box(*choice, pyramid.key, [&](WindowRead& window) {
        held = std::make_unique<RefinedVolume>(o, *choice, &window, lends, std::move(moving));
        return held->held_bytes();
      }, stats, failed);
      if (read) {  // (else the frame draws the opened level)
        refined_changed_ = true;
        rebuilt(indexed("volumes", i, "refined"), Quality::Full, frame);
      } else {
        stats.evicted_bytes += moving_bytes;  // a box that moved into a read that failed is gone
      }
    }
    if (follow && held->follow(o)) {  // the table and empty cells follow a transfer function edited meanwhile
      held->prepared().update_lut(held->prepared().full_step);
      held->prepared().update_empty();
    }
    if (held) {
      stats.level = held->box().level;
      stats.dims = held->box().dims();
      stats.held_bytes = held->held_bytes();
      left -= std::min<std::uint64_t>(left, stats.held_bytes);
      step = std::min(step, held->step_world());
    }
  }
  give_up_kept_boxes(0, frame);  // the boxes drawn and the kept ones within the budget
  for (RefinementStats& s : frame.refinement)
    for (std::size_t k = 0; k < volumes_.size(); ++k)
      if (static_cast<std::size_t>(volume_index_[k]) == s.volume)
        for (const KeptBox& b : kept_[k]) s.kept_bytes += b.box->held_bytes();
  std::erase_if(frame.refinement, [](const RefinementStats& s) {
    return !s.held_bytes && !s.evicted_bytes && !s.kept_bytes && s.error.empty();
  });
  // one lattice step for every volume of the eye pass (and the opened levels around a box): the finest
  for (std::size_t k = 0; k < volumes_.size(); ++k)
    for (PreparedVolume* pv : {volumes_[k].get(), refined_[k] ? &refined_[k]->prepared() : nullptr}) {
      if (!pv) continue;
      if (pv->full_step != step) pv->update_lut(step);
      pv->use(false);
    }
  return left;
}

void Renderer::refine_isosurfaces(const Camera& camera, std::uint64_t left, FrameResult& frame) {
  std::map<std::size_t, std::vector<std::size_t>> wanted;  // volume → its isosurfaces that extract points or ray cast
  for (std::size_t s = 0; s < scene_.isosurfaces.size(); ++s) {
    const IsosurfaceObject& o = scene_.isosurfaces[s];
    const VolumeObject& v = scene_.volumes[o.volume];
    if (o.method != IsosurfaceMethod::Mesh && v.pyramid && !v.volume->is_window()) wanted[o.volume].push_back(s);
  }
  for (auto it = refined_surfaces_.begin(); it != refined_surfaces_.end();) {  // a volume no longer wanted gives its box up
    if (wanted.count(it->first)) {
      ++it;
      continue;
    }
    RefinementStats stats;
    stats.volume = it->first;
    stats.evicted_bytes = it->second.held_bytes();
    if (stats.evicted_bytes && it->second.own) frame.refinement.push_back(stats);
    it = refined_surfaces_.erase(it);
    refined_changed_ = true;  // the light pass casts from it no more
  }
  for (const auto& entry : wanted) {
    const std::size_t i = entry.first;  // (a structured binding cannot be captured by clang 14's lambdas)
    const std::vector<std::size_t>& surfaces = entry.second;
    const VolumeObject& o = scene_.volumes[i];
    const PyramidSource& pyramid = *o.pyramid;
    const RefinedVolume* drawn = nullptr;  // the visible volume's box, when this frame draws one
    for (std::size_t k = 0; k < volumes_.size() && k < refined_.size(); ++k)
      if (static_cast<std::size_t>(volume_index_[k]) == i && refined_[k]) drawn = refined_[k].get();
    RefinementStats stats;
    stats.volume = i;
    stats.opened_level = stats.level = pyramid.opened;
    auto found = refined_surfaces_.find(i);
    auto evict = [&](bool moves = false) {  // moves: its voxels go to the new box (not evicted)
      if (found == refined_surfaces_.end()) return;
      if (found->second.own && !moves) stats.evicted_bytes += found->second.held_bytes();
      refined_surfaces_.erase(found);
      found = refined_surfaces_.end();
      refined_changed_ = true;
    };
    if (drawn) {  // the hierarchy over the box the eye pass draws the volume from
      if (found == refined_surfaces_.end() || found->second.voxels != drawn->object().volume) {
        evict();
        RefinedSurfaces r{drawn->box(), pyramid.key, drawn->object().volume, nullptr, std::make_shared<const GridTree>(*drawn->object().volume), {}};
        found = refined_surfaces_.emplace(i, std::move(r)).first;
        refined_changed_ = true;
        rebuilt(indexed("volumes", i, "refined_hierarchy"), Quality::Full, frame);
      }
    } else {
      // its own box: voxels and the hierarchy's ~0.14 bytes a voxel from what is left
      const double voxel = static_cast<double>(scalar_size(pyramid.type));
      const auto for_voxels = static_cast<std::uint64_t>(static_cast<double>(left) * voxel / (voxel + 0.15));
      const std::optional<RefinementChoice> choice =
          choose_refinement(camera, pyramid, pyramid.bounds(*o.volume), for_voxels, false, true);
      const bool keep = found != refined_surfaces_.end() && found->second.own && found->second.key == pyramid.key &&
                        box_serves(found->second.box, found->second.held_bytes(), pyramid, choice, left);
      std::optional<FailedRefinement>& failed = surface_refine_failures_[i];
      if (keep) {
        // the box held serves this view too
      } else if (choice && failed && failed->covers(pyramid, *choice)) {
        evict();
        stats.error = failed->error;
      } else if (!choice) {
        evict();
      } else {
        // a box of the same store and level held until now gives the new one the voxels both hold: lent
        // when the budget holds the two (and given up after), else moved (its memory becomes the new
        // box's, those voxels moved in place, Volume::move_voxels)
        auto with_hierarchy = [&](const LevelBox& b) { return refined_bytes(b, pyramid.type, false) * 6 / 5; };
        std::optional<HeldBox> held;
        std::shared_ptr<Volume> moving;
        if (found != refined_surfaces_.end() && found->second.own && found->second.key == pyramid.key &&
            found->second.box.level == choice->box.level && overlaps(found->second.box, choice->box)) {
          const RefinedSurfaces& old = found->second;
          held = HeldBox{old.box.lo, old.box.hi, old.own.get()};
          if (old.held_bytes() + with_hierarchy(choice->box) > left) {
            moving = old.own;
            held->storage = moving.get();
          }
        }
        const std::uint64_t moving_bytes = moving ? found->second.held_bytes() : 0;
        if (!held || moving) evict(moving != nullptr);  // (a box that lends is given up once the new one is read)
        give_up_kept_boxes(with_hierarchy(choice->box), frame);
        std::optional<RefinedSurfaces> made;
        const bool read = read_refinement_box(*choice, pyramid.key, [&](WindowRead& window) {
          auto voxels = std::make_shared<Volume>(pyramid.read_box(choice->box.level, choice->box.lo, choice->box.hi, &window, held ? &*held : nullptr));
          auto tree = std::make_shared<const GridTree>(*voxels);
          made = RefinedSurfaces{choice->box, pyramid.key, voxels, voxels, std::move(tree), {}};
          return made->held_bytes();
        }, stats, failed);
        moving.reset();
        evict();
        if (read) {  // (else the isosurfaces keep the opened level)
          found = refined_surfaces_.emplace(i, std::move(*made)).first;
          refined_changed_ = true;
          rebuilt(indexed("volumes", i, "refined_hierarchy"), Quality::Full, frame);
        } else {
          stats.evicted_bytes += moving_bytes;  // a box that moved into a read that failed is gone
        }
      }
    }
    if (found != refined_surfaces_.end()) {
      RefinedSurfaces& r = found->second;
      // the box's surfaces, made again for an isovalue edited or an isosurface new here (the refined
      // casters point at their ray casters)
      const auto before = r.surfaces.size();
      std::erase_if(r.surfaces, [&](const auto& e) { return std::find(surfaces.begin(), surfaces.end(), e.first) == surfaces.end(); });
      refined_changed_ = refined_changed_ || r.surfaces.size() != before;
      for (std::size_t s : surfaces) {
        std::unique_ptr<PreparedIsosurface>& fine = r.surfaces[s];
        if (!fine || fine->raycaster.isovalue() != scene_.isosurfaces[s].value) {
          fine = std::make_unique<PreparedIsosurface>(r.tree, scene_.isosurfaces[s]);
          refined_changed_ = true;
        }
        fine->object = &scene_.isosurfaces[s];
      }
      if (r.own) {
        stats.level = r.box.level;
        stats.dims = r.box.dims();
        stats.held_bytes = r.held_bytes();
        left -= std::min<std::uint64_t>(left, stats.held_bytes);
      }
    }
    const bool listed = std::any_of(frame.refinement.begin(), frame.refinement.end(), [&](const RefinementStats& s) { return s.volume == i; });
    if (!listed && (stats.held_bytes || stats.evicted_bytes || !stats.error.empty())) frame.refinement.push_back(stats);
  }
}

std::vector<bool> Renderer::volume_gradients_stored() const {
  std::vector<bool> stored;
  for (const auto& pv : volumes_) stored.push_back(pv->gradients_stored());
  return stored;
}

std::size_t Renderer::bvh_memory_bytes() const {
  return (bvh_ ? bvh_->memory_bytes() : 0) + (casting_bvh_ ? casting_bvh_->memory_bytes() : 0);
}

void Renderer::prepare(Quality quality, const Camera* refine_for, FrameResult& frame) {
  settings_ = quality == Quality::Preview ? preview_settings(scene_, full_shadow_ms_) : scene_;
  building_ = quality;
  // a full frame rebuilds what a preview built coarser
  if (quality == Quality::Full) {
    const std::vector<std::string> held = structures();
    for (const auto& [name, q] : built_at_)
      if (q == Quality::Preview && std::find(held.begin(), held.end(), name) != held.end()) stale_.insert(name);
  }
  Timer prep;
  prepare_volumes(frame);
  check_cancelled();
  const std::uint64_t left = refine_for ? refine_volumes(*refine_for, frame) : 0;
  prepare_particles(frame);
  prepare_isosurfaces(frame);
  if (refine_for) refine_isosurfaces(*refine_for, left, frame);
  frame.prepare_ms = prep.elapsed_ms() - frame.bvh_ms;
  check_cancelled();
  // the structures that hang off each other: SAT → casters → ambient and every light's shadows
  const bool wants_sat = needs_extinction_sat(scene_);
  // a distributed frame's SAT is summed over the bricks (built again for another slab)
  const std::optional<SampleSlab> sat_slab = frame_brick_ ? std::optional<SampleSlab>(frame_brick_->slab) : std::nullopt;
  const bool other_slab = sat_slab.has_value() != sat_slab_.has_value() ||
                          (sat_slab && (sat_slab->z_lo != sat_slab_->z_lo || sat_slab->z_hi != sat_slab_->z_hi));
  if (stale("sat") || (wants_sat && !sat_) || (!wants_sat && sat_) || (wants_sat && other_slab)) {
    stale_.insert("casters");
    sat_.reset();
    if (wants_sat) {
      const VolumeObject* v = scene_.visible_volume();
      if (!v) throw Error("shadows.technique / ambient.technique: the extinction techniques need a visible volume");
      Timer t;
      sat_ = make_extinction_sat(*v, nullptr);
      sat_slab_ = sat_slab;
      frame.sat_ms = t.elapsed_ms();
      rebuilt("sat", quality, frame);
    }
    stale_.erase("sat");
  }
  if (stale("casters") || !casters_) {
    casters_ = make_casters({}, false, sat_.get());
    refined_casters_.reset();
    refined_sat_.reset();
    rebuilt("casters", quality, frame);
    light_structures_stale();
  }
  // a full frame casts from the refined boxes held (a preview from the opened levels, keeping what a
  // full frame built while nothing it casts changes)
  if (quality == Quality::Full && update_refined_casters(frame)) {
    if (refined_casters_) rebuilt("casters.refined", quality, frame);
    light_structures_stale();
  }
  if (stale("ambient")) {
    // a technique that keeps what it built (particle_ao's cones under ambient.reuse) is built again
    std::unique_ptr<AmbientTechnique> ambient;
    if (ambient_ && ambient_->keeps_state_across_builds() && ambient_settings_ == settings_.ambient) ambient = std::move(ambient_);
    else ambient = make_ambient_technique(settings_.ambient);
    ambient_.reset();
    ambient_settings_ = settings_.ambient;
    if (ambient) {
      Timer t;
      // the ambient technique's occluders: every object of its kinds, casting or not
      occluders_ = std::make_unique<ShadowCasters>(frame_casters().restricted_to(ambient_occluders(scene_)));
      // a distributed frame: a technique that combines over bricks builds from this brick's share
      if (frame_brick_ && ambient->combines_over_bricks()) *occluders_ = occluders_->restricted_to_brick(*frame_brick_);
      ambient->build(*occluders_);
      ambient_ = std::move(ambient);
      repack_ambient_ = true;
      frame.ambient_ms = t.elapsed_ms();
      frame.ambient_kept = ambient_->kept_from_last_build();
      rebuilt("ambient", quality, frame);
    }
    stale_.erase("ambient");
  }
}

void Renderer::update_shadows(const std::vector<Light>& lights, Quality quality, std::uint32_t sample, const ShadowBrick* brick,
                              FrameResult& frame) {
  if (shadows_.size() != lights.size()) {
    shadows_.clear();
    built_for_.clear();
    seed_of_.clear();
  }
  full_shadow_ms_of_.resize(lights.size());
  const bool any = !shadow_assignments(scene_).empty();
  const ParamSpec* seed_key = seed_param(scene_);
  const bool seeded = seed_key != nullptr;
  const std::uint64_t seed = seeded ? static_cast<std::uint64_t>(seed_key->integer(scene_.shadows.params)) + sample : 0;
  Scene with_seed;
  const Scene* settings = &settings_;
  if (seeded && sample > 0) {
    with_seed = settings_;
    with_seed.shadows.params.set(seed_key->key, static_cast<std::int64_t>(seed));
    settings = &with_seed;
  }
  for (std::size_t i = 0; i < lights.size(); ++i) {
    const std::string name = indexed("lights", i, "shadows");
    const bool have = i < shadows_.size();
    if (have && !stale(name) && same_shadow_geometry(built_for_[i], lights[i]) && (!seeded || seed_of_[i] == seed)) continue;
    Timer t;
    auto s = std::make_unique<LightShadows>(*settings, frame_casters(), lights[i], brick);
    if (quality == Quality::Full) full_shadow_ms_of_[i] = t.elapsed_ms();
    if (have) {
      shadows_[i] = std::move(s);
      built_for_[i] = lights[i];
      seed_of_[i] = seed;
    } else {
      shadows_.push_back(std::move(s));
      built_for_.push_back(lights[i]);
      seed_of_.push_back(seed);
    }
    if (any) rebuilt(name, quality, frame);
    repack_light_.resize(lights.size(), true);
    repack_light_[i] = true;
    stale_.erase(name);
    check_cancelled();
  }
  for (auto it = stale_.begin(); it != stale_.end();)  // lights that are gone
    it = it->rfind("lights.", 0) == 0 ? stale_.erase(it) : std::next(it);
  full_shadow_ms_ = 0;
  for (double ms : full_shadow_ms_of_) full_shadow_ms_ += ms;
}

FrameResult Renderer::render(const Camera& camera, const std::vector<Light>& lights, const FrameRequest& request) {
  const CancelScope scope(request.cancel);
  if (request.quality == Quality::Full || request.preview_divisor <= 1) return render_at(camera, lights, request);
  Camera small = camera;
  const int d = request.preview_divisor;
  small.width = std::max(1, (camera.width + d - 1) / d);
  small.height = std::max(1, (camera.height + d - 1) / d);
  FrameResult f = render_at(small, lights, request);
  if (!request.enlarge_preview) return f;
  Image full(camera.width, camera.height);
  full.pixels() = enlarged(f.image.pixels(), small.width, small.height, camera.width, camera.height);
  f.image = std::move(full);
  f.alpha = enlarged(f.alpha, small.width, small.height, camera.width, camera.height);
  f.depth = enlarged(f.depth, small.width, small.height, camera.width, camera.height);
  return f;
}

FrameResult Renderer::render_at(const Camera& camera, const std::vector<Light>& lights, const FrameRequest& request) {
  FrameResult frame;
  frame.quality = request.quality;
  frame.sample = request.sample;
  Timer total;
  std::optional<ShadowBrick> brick;
  if (request.reduction != nullptr && (request.slab || request.own_spheres))
    brick = ShadowBrick{request.slab.value_or(SampleSlab{}), request.reduction, request.own_spheres};
  frame_brick_ = brick ? &*brick : nullptr;
  // a full frame draws pyramids opened coarse from a finer box where the camera looks, and casts from it;
  // a preview (or a rank's slab) from the opened level
  const bool refined_frame = request.quality == Quality::Full && !request.slab;
  prepare(request.quality, refined_frame ? &camera : nullptr, frame);
  frame_brick_ = nullptr;
  Timer build;
  update_shadows(lights, request.quality, request.sample, brick ? &*brick : nullptr, frame);
  update_light_cache();
  frame.build_ms = build.elapsed_ms();
  if (first_frame_) {
    prepare_ms_ = frame.prepare_ms;
    first_frame_ = false;
  }

  Timer render;
  // The opaque surfaces: spheres, isosurfaces, planes.
  if (particles_) {
    const auto hits_key = std::make_pair(camera, scene_.sphere_rasterizer);
    if (hits_for_ != hits_key) {
      Timer t;
      hits_ = scene_.sphere_rasterizer == SphereRasterizer::Embree ? trace_spheres(*bvh_, camera) : splat_spheres(*particles_, *sphere_order_, camera);
      hits_for_ = hits_key;
      surfaces_for_.reset();
      frame.hits_ms = t.elapsed_ms();
    }
    frame.sphere_pixels = hits_.covered();
  }
  std::vector<IsoPoints> eye(isosurfaces_.size());
  for (std::size_t s = 0; s < isosurfaces_.size(); ++s) {
    IsosurfaceFrameStats one;
    const bool had_mesh = isosurfaces_[s]->mesh != nullptr;
    const ClipPlanes clip = scene_.clip_planes_for(scene_.isosurfaces[s].clip);
    // a full frame draws the surface inside a refined box from the box, and the opened level around it
    const auto refined = refined_frame ? refined_surfaces_.find(scene_.isosurfaces[s].volume) : refined_surfaces_.end();
    const PreparedIsosurface* finer =
        refined != refined_surfaces_.end() && refined->second.surfaces.count(s) ? refined->second.surfaces.at(s).get() : nullptr;
    eye[s] = penumbra::isosurface_eye_points(camera, *isosurfaces_[s], one, clip, finer);
    if (!had_mesh && isosurfaces_[s]->mesh) rebuilt(indexed("isosurfaces", s, "mesh"), Quality::Full, frame);
    frame.isosurface.add(one);
    frame.isosurface.points += eye[s].size();
  }
  check_cancelled();
  Timer shade;
  const SurfaceInputs surface_in{&scene_, &camera, particles_.get(), particle_offsets_, particle_objects_,
                                 particles_ ? &hits_ : nullptr, eye};
  frame.surfaces_kept = surfaces_for_ == camera;
  if (!frame.surfaces_kept) {
    surfaces_for_.reset();  // (a list left half-written by an exception is never taken for a whole one)
    visible_surfaces(surface_in, surfaces_);
    const bool listed_anew_each_frame = !isosurfaces_.empty() || scene_.first_slice < scene_.planes.size();
    surfaces_for_ = listed_anew_each_frame ? std::nullopt : std::optional<Camera>(camera);
  }
  const VisibleSurfaces& surfaces = surfaces_;
  // Translucent planes (slices with opacity below 1) in front of them: receivers too, drawn over what
  // lies behind them. A brick of a data-parallel frame cannot order them with the other bricks' volumes.
  VisibleSurfaces glass;
  std::vector<float> glass_opacity;
  if (has_translucent_planes(scene_) && request.slab)
    throw Error("slices: a translucent slice ('opacity' below 1) cannot be drawn in a data-parallel (mpirun) frame; give 'opacity': 1");
  translucent_surfaces(scene_, camera, surfaces.distance, glass, glass_opacity);
  frame.isosurface.shade_ms += shade.elapsed_ms();

  // View-dependent shadow work for this frame's receivers.
  Timer fit;
  bool volume_samples = false;
  for (const auto& v : volumes_) volume_samples = volume_samples || v->object->receives_shadows;
  ShadowStats stats;
  for (const auto& s : shadows_)
    for (const auto& t : s->techniques()) frame.refit = frame.refit || t->view_dependent();
  // bricks of an isosurface, when a fit reads the receivers: see receivers_shown
  const bool shown_only = frame.refit && brick && request.slab && !isosurfaces_.empty();
  const std::vector<SurfacePoint> shown = shown_only ? receivers_shown(*brick, camera, surfaces) : std::vector<SurfacePoint>{};
  std::span<const SurfacePoint> receivers = shown_only ? std::span<const SurfacePoint>(shown) : surfaces.points;
  std::vector<SurfacePoint> with_glass;
  if (!glass.points.empty()) {
    with_glass.assign(receivers.begin(), receivers.end());
    with_glass.insert(with_glass.end(), glass.points.begin(), glass.points.end());
    receivers = with_glass;
  }
  for (auto& s : shadows_) {
    s->fit_to_receivers(receivers, volume_samples, refined_frame);
    s->add_stats(stats);
  }
  frame.isosurface.shadow_ms = fit.elapsed_ms();
  frame.isosurface.light_points = stats.light_points;
  frame.isosurface.holes = stats.holes;
  frame.issm_rings = stats.issm_rings;
  check_cancelled();

  std::vector<const LightShadows*> shadow_ptrs;
  for (const auto& s : shadows_) shadow_ptrs.push_back(s.get());
  shade.reset();
  Image opaque = shade_surfaces(scene_, camera, surfaces, lights, shadow_ptrs, ambient_.get());
  const Image glass_color = glass.points.empty() ? Image() : shade_surfaces(scene_, camera, glass, lights, shadow_ptrs, ambient_.get());
  frame.isosurface.shade_ms += shade.elapsed_ms();
  check_cancelled();

  // The volumes in front of them.
  const std::size_t pixels = surfaces.distance.size();
  frame.depth = surfaces.distance;
  frame.alpha.assign(pixels, 0.0f);
  for (std::size_t p = 0; p < pixels; ++p) frame.alpha[p] = std::isfinite(surfaces.distance[p]) ? 1.0f : 0.0f;
  if (request.slab) drop_surfaces_outside(*request.slab, camera, surfaces.distance, opaque, frame.alpha);
  if (volumes_.empty()) {
    frame.image = std::move(opaque);
    for (const std::uint32_t p : glass.pixel) {  // a translucent plane over the surface behind it
      const float a = glass_opacity[p];
      const int x = static_cast<int>(p % static_cast<std::uint32_t>(camera.width)), y = static_cast<int>(p / static_cast<std::uint32_t>(camera.width));
      frame.image.at(x, y) = glass_color.at(x, y) * a + frame.image.at(x, y) * (1 - a);
      frame.alpha[p] = a + (1 - a) * frame.alpha[p];
      if (a >= 0.5f) frame.depth[p] = glass.distance[p];
    }
  } else {
    // a refined box: inside the one volume's opened level, or in the place of a volume beside others
    auto refined_box = [&](std::size_t k) { return refined_frame && k < refined_.size() && refined_[k] ? &refined_[k]->prepared() : nullptr; };
    const PreparedVolume* inside = volumes_.size() == 1 ? refined_box(0) : nullptr;
    std::vector<const PreparedVolume*> volume_ptrs;
    for (std::size_t k = 0; k < volumes_.size(); ++k)
      volume_ptrs.push_back(!inside && refined_box(k) ? refined_box(k) : volumes_[k].get());
    const OpaqueLayer layer{&surfaces.distance, &opaque};
    const TranslucentLayer glass_layer{&glass.distance, &glass_color, &glass_opacity};
    VolumeFrame vf = render_volume_frame(
        RayCastInputs{&scene_, &camera, volume_ptrs, lights, shadow_ptrs, ambient_.get(), light_cache_.get(), light_slot_,
                      &layer, glass.points.empty() ? nullptr : &glass_layer, request.sample, request.slab ? &*request.slab : nullptr, inside});
    frame.image = std::move(vf.image);
    frame.volume_samples = vf.samples;
    frame.volume_shaded_samples = vf.shaded_samples;
    for (std::size_t p = 0; p < pixels; ++p) {
      frame.alpha[p] = frame.alpha[p] + (1 - frame.alpha[p]) * vf.opacity[p];
      frame.depth[p] = std::min(frame.depth[p], vf.half_depth[p]);
    }
  }
  check_cancelled();
  if (eye.size() == 1) isosurface_eye_points_ = std::move(eye.front());
  else {
    isosurface_eye_points_.clear();
    for (const IsoPoints& e : eye) isosurface_eye_points_.insert(isosurface_eye_points_.end(), e.begin(), e.end());
  }
  frame.render_ms = render.elapsed_ms();
  frame.total_ms = total.elapsed_ms();
  return frame;
}

void Renderer::update_light_cache() {
  // the terms kept on the SAT's cells: the volume ambient technique's and each sat_cone light's
  const auto* ambient = dynamic_cast<const VolumeAmbientOcclusion*>(ambient_.get());
  const CellLattice* lattice = ambient ? &ambient->cache().lattice() : nullptr;
  const std::size_t free_slots = static_cast<std::size_t>(LightCache::kMaxChannels - (ambient ? 3 : 0));
  std::vector<const SatConeShadows*> cones(shadows_.size(), nullptr);
  std::vector<int> slots(shadows_.size(), -1);
  std::size_t packed = 0;
  for (std::size_t l = 0; l < shadows_.size() && packed < free_slots; ++l) {
    const auto& techniques = shadows_[l]->techniques();
    if (techniques.size() != 1) continue;  // a product over caster groups is asked as a whole
    const auto* cone = dynamic_cast<const SatConeShadows*>(techniques.front().get());
    if (!cone || (lattice && !cone->cache().lattice().same_cells(*lattice))) continue;
    if (!lattice) lattice = &cone->cache().lattice();
    cones[l] = cone;
    slots[l] = static_cast<int>(packed++);
  }
  repack_light_.resize(shadows_.size(), true);
  if (packed + (ambient ? 1 : 0) < 2 || volumes_.empty()) {  // one term alone gains nothing from packing
    light_cache_.reset();
    light_slot_.assign(shadows_.size(), -1);
    return;
  }
  if (!light_cache_ || slots != light_slot_ || light_cache_->has_ambient() != (ambient != nullptr) ||
      !light_cache_->lattice().same_cells(*lattice)) {
    light_cache_ = std::make_unique<LightCache>(*lattice, ambient != nullptr, packed);
    light_slot_ = slots;
    repack_ambient_ = true;
    std::fill(repack_light_.begin(), repack_light_.end(), true);
  }
  if (ambient && repack_ambient_) light_cache_->set_ambient(ambient->cache());
  repack_ambient_ = false;
  for (std::size_t l = 0; l < shadows_.size(); ++l) {
    if (cones[l] && repack_light_[l]) light_cache_->set_light(static_cast<std::size_t>(slots[l]), cones[l]->cache());
    repack_light_[l] = false;
  }
}

std::size_t Renderer::shadow_memory_bytes() const {
  std::size_t bytes = 0;
  for (const auto& s : shadows_) bytes += s->memory_bytes();
  return bytes;
}

}  // namespace penumbra
