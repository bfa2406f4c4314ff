#include "penumbra/lighting/shadow_casters.h"

#include "penumbra/core/error.h"
#include "penumbra/lighting/shared_params.h"

namespace penumbra {

CastingVolume::CastingVolume(const VolumeObject& o, const MacrocellGrid& g, float step, const ClipPlanes& clip_planes)
    : volume(o.volume.get()),
      box(o.volume->bounds()),
      extent(o.pyramid && !o.volume->is_window() ? o.pyramid->bounds(*o.volume) : box),
      lut(o.shadow_tf(), o.volume->min_value(), o.volume->max_value(), step / o.reference_step(), 4096, o.compositing),
      grid(&g),
      empty(g.empty_cells(lut)),
      achromatic(o.compositing == Compositing::Extinction),
      clip(clip_planes) {}

ShadowCasters::ShadowCasters(const Scene& scene, std::span<const MacrocellGrid* const> grids, std::span<const FinerBox> finer) {
  const float steps_in_voxels = light_step_voxels(scene.shadows.params);
  const auto casts = [&](std::size_t i) { return i < grids.size() && grids[i] && scene.volumes[i].casts_shadows; };
  const auto finer_of = [&](std::size_t i) { return i < finer.size() && finer[i].object ? &finer[i] : nullptr; };
  // one lattice for every volume: the finest of their voxels (a refined box's among them)
  float voxel = kInfinity;
  for (std::size_t i = 0; i < scene.volumes.size(); ++i)
    if (casts(i)) {
      voxel = std::min(voxel, scene.volumes[i].voxel_step());
      if (const FinerBox* f = finer_of(i)) voxel = std::min(voxel, f->object->voxel_step());
    }
  if (voxel < kInfinity) step_ = steps_in_voxels * voxel;
  for (std::size_t i = 0; i < scene.volumes.size(); ++i)
    if (casts(i)) {
      const ClipPlanes clip = scene.clip_planes_for(scene.volumes[i].clip);
      auto cv = std::make_shared<CastingVolume>(scene.volumes[i], *grids[i], step_, clip);
      if (const FinerBox* f = finer_of(i)) {
        if (f->object->volume->type() != scene.volumes[i].volume->type())
          throw Error("volumes[" + std::to_string(i) + "]: a refined box's voxel type differs from its opened level's");
        cv->finer = std::make_shared<const CastingVolume>(*f->object, *f->grid, step_, clip);
      }
      volumes_.push_back(std::move(cv));
    }
  for (const Plane& p : scene.planes)
    if (p.casts_shadows) planes_.push_back(p);
  update_bounds();
}

void ShadowCasters::set_spheres(const CastingSpheres& spheres) {
  spheres_ = spheres;
  update_bounds();
}

void ShadowCasters::add_isosurface(const IsosurfaceRaycaster& raycaster, const GridTree& tree, std::uint32_t object,
                                   const ClipPlanes& clip, CastingIsosurface::Finer finer) {
  const Volume& volume = tree.volume();
  isosurfaces_.push_back(CastingIsosurface{&raycaster, &tree, raycaster.isovalue(), object, isosurface_offset(volume.spacing()), volume.bounds(), clip,
                                           finer, finer.tree ? finer.tree->volume().bounds() : Box3{}});
  update_bounds();
}

void ShadowCasters::update_bounds() {
  Box3 b;
  for (const auto& v : volumes_) b.extend(v->box);
  for (const auto& i : isosurfaces_) b.extend(i.bounds);
  if (spheres_.set) b.extend(spheres_.bounds);
  // Planes join only when there is nothing else: a light frustum fitted to the other casters already
  // covers every receiver they can shadow, and a large floor would spread the map's texels thin.
  if (b.empty())
    for (const auto& p : planes_) b.extend(p.bounds());
  bounds_ = b;
  epsilon_ = 1e-4f * (b.empty() ? 1.0f : std::max(b.radius(), 1e-6f));
}

ShadowCasters ShadowCasters::restricted_to(KindMask kinds) const {
  ShadowCasters c = *this;
  if (!(kinds & kind_bit(ObjectKind::Volume))) c.volumes_.clear();
  if (!(kinds & kind_bit(ObjectKind::Spheres))) c.spheres_ = CastingSpheres{};
  if (!(kinds & kind_bit(ObjectKind::Isosurface))) c.isosurfaces_.clear();
  if (!(kinds & kind_bit(ObjectKind::Plane))) c.planes_.clear();
  c.update_bounds();
  return c;
}

ShadowCasters ShadowCasters::restricted_to_brick(const ShadowBrick& brick) const {
  ShadowCasters c = *this;
  c.brick_ = brick;
  return c;
}

float ShadowCasters::surface_hit(const Ray& r, float t0, float t1, bool finer_surfaces) const {
  float best = t1;
  for (const auto& p : planes_) best = std::min(best, p.intersect(r, t0, best));
  if (spheres_.set && !spheres_.set->spheres.empty()) {
    if (!spheres_.bvh) throw Error("internal: spheres cast shadows by rays but no BVH was built");
    // Embree takes tnear >= 0: a ray that starts behind its origin (a directional map's texel line)
    // restarts where it enters the spheres' box
    float a = t0, b = best;
    if (spheres_.bounds.clip(r, a, b, t0, best)) {
      const float shift = a < 0 ? a : 0.0f;
      const SphereHit h = spheres_.bvh->first_hit(Ray{r.at(shift), r.direction}, a - shift, best - shift);
      if (h.id != kNoSphere) best = std::min(best, h.t + shift);
    }
  }
  for (const auto& iso : isosurfaces_) {
    float a = t0, b = best;  // the part of the ray the clip planes keep
    if (!iso.clip.keep(r, a, b)) continue;
    // the opened level's surface before a refined box, the box's in it, the opened level's behind it
    const float t = finer_surfaces && iso.finer.raycaster ? iso.raycaster->first_hit(r, a, b, *iso.finer.raycaster)
                                                          : iso.raycaster->first_hit(r, a, b);
    if (t > t0) best = std::min(best, t);
  }
  return best < t1 ? best : kInfinity;
}

Vec3 ShadowCasters::ray_origin(const SurfacePoint& p, const Vec3& towards) const {
  const Vec3 n = dot(p.normal, towards) >= 0 ? p.normal : -p.normal;
  float off = epsilon_;
  if (spheres_.set && p.self < spheres_.set->size())
    off = std::max(epsilon_, 1e-3f * spheres_.set->spheres[p.self].radius);  // Embree's precision on its own sphere
  if (p.kind == ObjectKind::Isosurface)
    for (const auto& iso : isosurfaces_)
      if (iso.object == p.object) off = std::max(off, iso.offset);
  return p.position + n * off;
}

const ExtinctionSat& ShadowCasters::extinction_sat() const {
  if (!sat_) throw Error("the extinction techniques (sat_cone, sat_shells, sampled_ao) need a visible volume");
  return *sat_;
}

}  // namespace penumbra
