#include "penumbra/render/renderer.h"

#include <algorithm>
#include <map>

#include "penumbra/core/error.h"
#include "penumbra/core/timer.h"
#include "penumbra/particles/implicit_sphere_shadow_map.h"
#include "penumbra/particles/particle_registry.h"
#include "penumbra/particles/sphere_hits.h"
#include "penumbra/render/particle_frame.h"
#include "penumbra/render/volume_raycaster.h"
#include "penumbra/scene/technique_catalog.h"
#include "penumbra/shadows/ray_traced.h"
#include "penumbra/shadows/registry.h"

namespace penumbra {

namespace {

// Rebuilds the structure of every light that differs from the one it was built for (all of them when
// the number of lights changed); true when any was rebuilt.
template <class Technique, class Make>
bool rebuild_changed_lights(std::vector<std::unique_ptr<Technique>>& techniques, std::vector<Light>& built_for,
                            const std::vector<Light>& lights, Make&& make) {
  if (techniques.size() != lights.size()) {
    techniques.clear();
    built_for.clear();
  }
  bool rebuilt = false;
  for (std::size_t i = 0; i < lights.size(); ++i) {
    if (i < techniques.size() && built_for[i] == lights[i]) continue;
    auto technique = make(lights[i]);
    if (i < techniques.size()) {
      techniques[i] = std::move(technique);
      built_for[i] = lights[i];
    } else {
      techniques.push_back(std::move(technique));
      built_for.push_back(lights[i]);
    }
    rebuilt = true;
  }
  return rebuilt;
}

}  // namespace

Renderer::Renderer(Scene scene) : scene_(std::move(scene)) {
  Timer timer;
  prepare();
  prepare_particles();
  prepare_isosurfaces();
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

void Renderer::prepare_particles() {
  if (!scene_.has_particles()) return;
  if (scene_.particles.size() == 1) {
    particles_ = scene_.particles.front().set;
  } else {  // several files: one set, so that every sphere shadows every other
    auto merged = std::make_shared<ParticleSet>();
    for (const auto& p : scene_.particles) {
      merged->spheres.insert(merged->spheres.end(), p.set->spheres.begin(), p.set->spheres.end());
      merged->colors.insert(merged->colors.end(), p.set->colors.begin(), p.set->colors.end());
    }
    particles_ = std::move(merged);
  }
  particle_scene_.particles = particles_.get();
  particle_scene_.bounds = particles_->bounds();
}

void Renderer::prepare_isosurfaces() {
  std::map<std::size_t, std::shared_ptr<const GridTree>> trees;  // one hierarchy per volume
  for (const IsosurfaceObject& o : scene_.isosurfaces) {
    auto& tree = trees[o.volume];
    if (!tree) tree = std::make_shared<const GridTree>(*scene_.volumes[o.volume].volume);
    isosurfaces_.push_back(std::make_unique<PreparedIsosurface>(tree, o));
  }
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
    if (!has_surfaces()) {
      if (auto ambient = make_ambient_technique(scene_.ambient)) {
        Timer t;
        ambient->build(*medium_);
        ambient_ = std::move(ambient);
        frame.ambient_ms = t.elapsed_ms();
        frame.rebuilt.push_back("ambient");
      }
    }
    shadows_.clear();
    built_for_.clear();
    transfer_function_changed_ = false;
  }
  if (scene_.has_particles() && !particles_built_) {
    Timer t;
    if (scene_.sphere_rasterizer == SphereRasterizer::Embree || needs_sphere_bvh(scene_)) {
      bvh_ = std::make_unique<SphereBvh>(*particles_);
      particle_scene_.bvh = bvh_.get();
      frame.bvh_ms = t.elapsed_ms();
      frame.rebuilt.push_back("bvh");
    }
    if (auto ambient = make_particle_ambient_technique(scene_.ambient)) {
      Timer ta;
      ambient->build(particle_scene_);
      particle_ambient_ = std::move(ambient);
      frame.ambient_ms = ta.elapsed_ms();
      frame.rebuilt.push_back("ambient");
    }
    particles_built_ = true;
  }
  Timer build;
  const bool rebuilt = scene_.has_particles() ? update_sphere_shadows(lights) : false;
  // In a sphere or isosurface scene the volume is composited by depth and lit without shadows
  // (docs/scene-file.md).
  const bool volume_rebuilt = update_volume_shadows(lights);
  frame.build_ms = build.elapsed_ms();
  if (rebuilt || volume_rebuilt) frame.rebuilt.push_back("shadows");

  Timer render;
  if (has_surfaces()) {
    Image opaque;
    if (scene_.has_particles()) {
      opaque = render_particles(camera, lights, frame);
    } else {
      std::vector<PreparedIsosurface*> isos;
      for (auto& iso : isosurfaces_) isos.push_back(iso.get());
      SurfaceLayer layer = render_isosurface_frame(scene_, camera, isos, lights, isosurface_shadows_, frame.isosurface);
      opaque = std::move(layer.image);
      opaque_distance_ = std::move(layer.distance);
      isosurface_eye_points_ = std::move(layer.eye_points);
      // view-dependent shadows are built for every frame (paper 002 §4)
      const bool listed = std::find(frame.rebuilt.begin(), frame.rebuilt.end(), "shadows") != frame.rebuilt.end();
      if (scene_.shadows.technique != "none" && !listed) frame.rebuilt.push_back("shadows");
    }
    if (volume_) {
      std::vector<const ShadowTechnique*> shadow_ptrs;
      for (const auto& sh : shadows_) shadow_ptrs.push_back(sh.get());
      const OpaqueLayer layer{&opaque_distance_, &opaque};
      frame.image = render_volume_frame(RayCastInputs{&scene_, &camera, volume_.get(), lights, shadow_ptrs, nullptr, &layer});
    } else {
      frame.image = opaque;
    }
  } else {
    std::vector<const ShadowTechnique*> shadow_ptrs;
    for (const auto& sh : shadows_) shadow_ptrs.push_back(sh.get());
    frame.image = render_volume_frame(RayCastInputs{&scene_, &camera, volume_.get(), lights, shadow_ptrs, ambient_.get()});
  }
  frame.render_ms = render.elapsed_ms();
  frame.total_ms = total.elapsed_ms();
  return frame;
}

bool Renderer::update_volume_shadows(const std::vector<Light>& lights) {
  if (has_surfaces() && !volume_) return false;
  return rebuild_changed_lights(shadows_, built_for_, lights, [&](const Light& light) {
    std::unique_ptr<ShadowTechnique> technique;
    if (has_surfaces()) technique = std::make_unique<NoShadows>();
    else technique = make_shadow_technique(scene_.shadows);
    technique->build(*medium_, light);
    return technique;
  });
}

bool Renderer::update_sphere_shadows(const std::vector<Light>& lights) {
  return rebuild_changed_lights(sphere_shadows_, sphere_shadows_for_, lights, [&](const Light& light) {
    auto technique = make_sphere_shadow_technique(scene_.shadows);
    technique->build(particle_scene_, light);
    return technique;
  });
}

Image Renderer::render_particles(const Camera& camera, const std::vector<Light>& lights, FrameResult& frame) {
  Timer t;
  const SphereHits hits = scene_.sphere_rasterizer == SphereRasterizer::Embree ? trace_spheres(*bvh_, camera)
                                                                               : splat_spheres(*particles_, camera);
  frame.hits_ms = t.elapsed_ms();
  frame.sphere_pixels = hits.covered();
  std::vector<const SphereShadowTechnique*> shadow_ptrs;
  for (const auto& sh : sphere_shadows_) shadow_ptrs.push_back(sh.get());
  const ParticleFrameInputs in{&scene_, &camera, particles_.get(), &hits, lights, shadow_ptrs, particle_ambient_.get()};
  VisibleSurfaces surfaces = visible_surfaces(in);
  if (scene_.shadows.technique == "issm") {
    for (auto& sh : sphere_shadows_) {
      auto& map = static_cast<ImplicitSphereShadowMap&>(*sh);
      if (scene_.shadows.rings < 0) frame.issm_rings = choose_issm_rings(map, surfaces.points);
      else frame.issm_rings = map.rings();
    }
  }
  Image image = shade_particle_frame(in, surfaces);
  opaque_distance_ = std::move(surfaces.distance);
  return image;
}

std::size_t Renderer::shadow_memory_bytes() const {
  std::size_t bytes = 0;
  for (const auto& s : shadows_) bytes += s->memory_bytes();
  for (const auto& s : sphere_shadows_) bytes += s->memory_bytes();
  for (const auto& s : isosurface_shadows_) bytes += s->memory_bytes();
  return bytes;
}

}  // namespace penumbra
