#include "penumbra/render/renderer.h"

#include <algorithm>
#include <map>

#include "penumbra/core/error.h"
#include "penumbra/core/timer.h"
#include "penumbra/particles/sphere_hits.h"
#include "penumbra/render/surface_frame.h"
#include "penumbra/render/volume_raycaster.h"
#include "penumbra/scene/technique_catalog.h"
#include "penumbra/shadows/registry.h"

namespace penumbra {

Renderer::Renderer(Scene scene) : scene_(std::move(scene)) {
  Timer timer;
  prepare_volumes();
  prepare_particles();
  prepare_isosurfaces();
  prepare_ms_ = timer.elapsed_ms();
}

void Renderer::prepare_volumes() {
  // one lattice for all visible volumes: the finest of their steps
  float step = kInfinity;
  for (const auto& v : scene_.volumes)
    if (v.visible) step = std::min(step, v.step_world());
  volumes_.clear();
  grids_.clear();
  grids_.resize(scene_.volumes.size());
  for (std::size_t i = 0; i < scene_.volumes.size(); ++i) {
    const VolumeObject& v = scene_.volumes[i];
    if (!v.visible) continue;
    volumes_.push_back(std::make_unique<PreparedVolume>(v, step));
  }
}

void Renderer::prepare_particles() {
  if (!scene_.has_particles()) return;
  // casting objects first, so that the casting spheres are a prefix with the same indices
  std::vector<std::uint32_t> order;
  for (int pass = 0; pass < 2; ++pass)
    for (std::size_t i = 0; i < scene_.particles.size(); ++i)
      if (scene_.particles[i].casts_shadows == (pass == 0)) order.push_back(static_cast<std::uint32_t>(i));
  std::size_t casting = 0;
  for (const auto& p : scene_.particles)
    if (p.casts_shadows) casting += p.set->size();
  if (order.size() == 1) {
    particles_ = scene_.particles.front().set;
  } else {  // several objects: one set, so that every sphere shadows every other
    auto merged = std::make_shared<ParticleSet>();
    for (std::uint32_t i : order) {
      const ParticleSet& s = *scene_.particles[i].set;
      merged->spheres.insert(merged->spheres.end(), s.spheres.begin(), s.spheres.end());
      merged->colors.insert(merged->colors.end(), s.colors.begin(), s.colors.end());
    }
    particles_ = std::move(merged);
  }
  std::uint32_t offset = 0;
  for (std::uint32_t i : order) {
    particle_offsets_.push_back(offset);
    particle_objects_.push_back(i);
    offset += static_cast<std::uint32_t>(scene_.particles[i].set->size());
  }
  particle_offsets_.push_back(offset);
  if (casting == particles_->size()) {
    casting_particles_ = particles_;
  } else if (casting > 0) {
    auto prefix = std::make_shared<ParticleSet>();
    prefix->spheres.assign(particles_->spheres.begin(), particles_->spheres.begin() + static_cast<std::ptrdiff_t>(casting));
    prefix->colors.assign(particles_->colors.begin(), particles_->colors.begin() + static_cast<std::ptrdiff_t>(casting));
    casting_particles_ = std::move(prefix);
  }
}

void Renderer::prepare_isosurfaces() {
  std::map<std::size_t, std::shared_ptr<const GridTree>> trees;  // one hierarchy per volume
  for (const IsosurfaceObject& o : scene_.isosurfaces) {
    auto& tree = trees[o.volume];
    if (!tree) tree = std::make_shared<const GridTree>(*scene_.volumes[o.volume].volume);
    isosurfaces_.push_back(std::make_unique<PreparedIsosurface>(tree, o));
  }
}

void Renderer::prepare_casters() {
  std::vector<const MacrocellGrid*> grids(scene_.volumes.size(), nullptr);
  std::size_t visible = 0;
  for (std::size_t i = 0; i < scene_.volumes.size(); ++i)
    if (scene_.volumes[i].visible) grids[i] = &volumes_[visible++]->grid;
  casters_ = std::make_unique<ShadowCasters>(scene_, grids);
  if (casting_particles_) {
    const SphereBvh* bvh = casting_particles_ == particles_ ? bvh_.get() : casting_bvh_.get();
    casters_->set_spheres(CastingSpheres{casting_particles_.get(), bvh, casting_particles_->bounds()});
  }
  for (std::size_t i = 0; i < isosurfaces_.size(); ++i)
    if (scene_.isosurfaces[i].casts_shadows)
      casters_->add_isosurface(isosurfaces_[i]->raycaster, *isosurfaces_[i]->tree, static_cast<std::uint32_t>(i));
  if (sat_) casters_->attach_extinction_sat(sat_.get());
  // the ambient technique's occluders: every object of its kinds, casting or not
  occluders_ = std::make_unique<ShadowCasters>(casters_->restricted_to(ambient_occluders(scene_)));
}

void Renderer::set_transfer_function(const TransferFunction& tf) {
  const VolumeObject* visible = scene_.visible_volume();
  if (!visible) throw Error("set_transfer_function: the scene has no visible volume");
  for (auto& v : scene_.volumes)
    if (&v == visible) v.transfer_function = tf;
  prepare_volumes();
  transfer_function_changed_ = true;
}

std::size_t Renderer::voxel_count() const {
  std::size_t n = 0;
  for (const auto& v : volumes_) n += v->volume->voxel_count();
  if (n == 0 && !isosurfaces_.empty()) n = isosurfaces_.front()->tree->volume().voxel_count();
  return n;
}

std::size_t Renderer::bvh_memory_bytes() const {
  return (bvh_ ? bvh_->memory_bytes() : 0) + (casting_bvh_ ? casting_bvh_->memory_bytes() : 0);
}

FrameResult Renderer::render(const Camera& camera, const std::vector<Light>& lights) {
  FrameResult frame;
  Timer total;
  if (scene_.has_particles() && !particles_built_) {
    if (needs_sphere_bvh(scene_)) {
      Timer t;
      bvh_ = std::make_unique<SphereBvh>(*particles_);
      if (casting_particles_ && casting_particles_ != particles_) casting_bvh_ = std::make_unique<SphereBvh>(*casting_particles_);
      frame.bvh_ms = t.elapsed_ms();
      frame.rebuilt.push_back("bvh");
    }
    particles_built_ = true;
    transfer_function_changed_ = true;  // the casters take the BVH
  }
  if (transfer_function_changed_) {
    sat_.reset();
    if (needs_extinction_sat(scene_)) {
      const VolumeObject* v = scene_.visible_volume();
      if (!v) throw Error("shadows.technique / ambient.technique: the extinction techniques need a visible volume");
      Timer t;
      // the casting spheres enter the table too (approximate ambient occlusion and cone shadows by spheres)
      sat_ = std::make_unique<ExtinctionSat>(*v->volume, v->shadow_tf(), v->compositing, v->reference_step(),
                                             scene_.light_cache.resolution, needs_extinction_colour(scene_),
                                             casting_particles_.get());
      frame.sat_ms = t.elapsed_ms();
      frame.rebuilt.push_back("sat");
    }
    shadows_.clear();
    built_for_.clear();
    ambient_.reset();
    prepare_casters();
    if (auto ambient = make_ambient_technique(scene_.ambient)) {
      Timer t;
      ambient->build(*occluders_);
      ambient_ = std::move(ambient);
      frame.ambient_ms = t.elapsed_ms();
      frame.rebuilt.push_back("ambient");
    }
    transfer_function_changed_ = false;
  }
  Timer build;
  if (update_shadows(lights)) frame.rebuilt.push_back("shadows");
  frame.build_ms = build.elapsed_ms();

  Timer render;
  // The opaque surfaces: spheres, isosurfaces, planes.
  SphereHits hits;
  if (particles_) {
    Timer t;
    hits = scene_.sphere_rasterizer == SphereRasterizer::Embree ? trace_spheres(*bvh_, camera) : splat_spheres(*particles_, camera);
    frame.hits_ms = t.elapsed_ms();
    frame.sphere_pixels = hits.covered();
  }
  std::vector<IsoPoints> eye(isosurfaces_.size());
  for (std::size_t s = 0; s < isosurfaces_.size(); ++s) {
    IsosurfaceFrameStats one;
    eye[s] = penumbra::isosurface_eye_points(camera, *isosurfaces_[s], one);
    frame.isosurface.add(one);
    frame.isosurface.points += eye[s].size();
  }
  Timer shade;
  const SurfaceInputs surface_in{&scene_, &camera, particles_.get(), particle_offsets_, particle_objects_,
                                 particles_ ? &hits : nullptr, eye};
  visible_surfaces(surface_in, surfaces_);
  const VisibleSurfaces& surfaces = surfaces_;
  frame.isosurface.shade_ms += shade.elapsed_ms();

  // View-dependent shadow work for this frame's receivers.
  Timer fit;
  bool volume_samples = false;
  for (const auto& v : volumes_) volume_samples = volume_samples || v->object->receives_shadows;
  bool view_dependent = false;
  ShadowStats stats;
  for (auto& s : shadows_) {
    s->fit_to_receivers(surfaces.points, volume_samples);
    s->add_stats(stats);
    for (const auto& t : s->techniques()) view_dependent = view_dependent || t->view_dependent();
  }
  frame.isosurface.shadow_ms = fit.elapsed_ms();
  frame.isosurface.light_points = stats.light_points;
  frame.isosurface.holes = stats.holes;
  frame.issm_rings = stats.issm_rings;
  if (view_dependent && std::find(frame.rebuilt.begin(), frame.rebuilt.end(), "shadows") == frame.rebuilt.end())
    frame.rebuilt.push_back("shadows");

  std::vector<const LightShadows*> shadow_ptrs;
  for (const auto& s : shadows_) shadow_ptrs.push_back(s.get());
  shade.reset();
  Image opaque = shade_surfaces(scene_, camera, surfaces, lights, shadow_ptrs, ambient_.get());
  frame.isosurface.shade_ms += shade.elapsed_ms();

  // The volumes in front of them.
  if (volumes_.empty()) {
    frame.image = std::move(opaque);
  } else {
    std::vector<const PreparedVolume*> volume_ptrs;
    for (const auto& v : volumes_) volume_ptrs.push_back(v.get());
    const OpaqueLayer layer{&surfaces.distance, &opaque};
    frame.image = render_volume_frame(RayCastInputs{&scene_, &camera, volume_ptrs, lights, shadow_ptrs, ambient_.get(), &layer});
  }
  if (eye.size() == 1) isosurface_eye_points_ = std::move(eye.front());
  else {
    isosurface_eye_points_.clear();
    for (const IsoPoints& e : eye) isosurface_eye_points_.insert(isosurface_eye_points_.end(), e.begin(), e.end());
  }
  frame.render_ms = render.elapsed_ms();
  frame.total_ms = total.elapsed_ms();
  return frame;
}

bool Renderer::update_shadows(const std::vector<Light>& lights) {
  if (shadows_.size() != lights.size()) {
    shadows_.clear();
    built_for_.clear();
  }
  bool rebuilt = false;
  for (std::size_t i = 0; i < lights.size(); ++i) {
    if (i < shadows_.size() && built_for_[i] == lights[i]) continue;
    auto s = std::make_unique<LightShadows>(scene_, *casters_, lights[i]);
    if (i < shadows_.size()) {
      shadows_[i] = std::move(s);
      built_for_[i] = lights[i];
    } else {
      shadows_.push_back(std::move(s));
      built_for_.push_back(lights[i]);
    }
    rebuilt = true;
  }
  return rebuilt && !shadows_.empty() && !shadow_assignments(scene_).empty();
}

std::size_t Renderer::shadow_memory_bytes() const {
  std::size_t bytes = 0;
  for (const auto& s : shadows_) bytes += s->memory_bytes();
  return bytes;
}

}  // namespace penumbra
