// What a light sees: every object of the scene that casts shadows — the visible volumes classified by
// their shadow transfer functions, the spheres, the isosurfaces and the opaque planes. Every shadow and
// ambient technique reads the scene through this one class, so they all share one colour model
// (DESIGN.md): a segment with opacity α and transmission colour t passes light of channel λ with
// probability 1 − α·(1 − t_λ); spheres, isosurfaces and planes pass nothing. A volume with extinction
// compositing (paper 001) attenuates every channel alike, t = 0, so a segment passes exp(−τ·Δs).
//
// Volumes that overlap are sampled at the same positions: a segment's midpoint is classified in every
// volume that holds it and the colour model's pass probabilities multiply, Π_v (1 − α_v·(1 − t_v,λ)),
// given back as one segment (α = 1 − Π(1 − α_v), t_λ from the product).
//
// A technique may take only some kinds of caster (the catalogue's `casters`): the renderer hands it a
// copy restricted to those kinds (restricted_to), and the product over the techniques of a light covers
// every caster once. The extinction techniques also read the volume's 3D summed area table from here,
// once the renderer has attached it.
//
// A volume drawn from a refined box of a finer pyramid level (render/view_refinement.h) casts from that
// box where it has one (CastingVolume::finer): a segment whose midpoint lies in the box is classified
// in the box's voxels, the rest in the opened level's, on one lattice as fine as the box's voxel. So
// every technique that marches the casters (shadow maps, the deep shadow map, the CSSM, ray-traced
// shadows and ambient occlusion) is refined where the camera looks; what
// reads the extinction SAT keeps the opened level.
#pragma once

#include <algorithm>
#include <cmath>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "penumbra/accel/extinction_sat.h"
#include "penumbra/accel/macrocell_grid.h"
#include "penumbra/core/color.h"
#include "penumbra/core/cutoffs.h"
#include "penumbra/core/math.h"
#include "penumbra/data/particles.h"
#include "penumbra/data/transfer_function.h"
#include "penumbra/geometry/isosurface_raycaster.h"
#include "penumbra/geometry/sphere_bvh.h"
#include "penumbra/geometry/sphere_order.h"
#include "penumbra/scene/scene.h"
#include "penumbra/accel/brick_reduction.h"
#include "penumbra/lighting/surface_point.h"

namespace penumbra {

// Light rays sample the volume once per voxel unless shadows.step says otherwise (lighting/
// shared_params.h): the light pass is only integrated, never shaded, so it does not need the eye's
// finer step; all techniques, the ray-traced reference included, use the same step, so their
// differences are the techniques' own.

struct MediumSegment {
  std::int64_t index;  // k: the segment [k·Δ, (k+1)·Δ] of the ray's lattice
  float t;             // midpoint of the part of the segment inside the volumes
  float t_begin, t_end;  // that part's ends (a full segment is [kΔ, (k+1)Δ]; the boxes cut the first and last)
  float alpha;         // opacity of that part (corrected for its length)
  Rgb transmission;    // t_λ: colour passed when the light interacts (the shadow TF's colour)
};

// One casting volume under its shadow transfer function, with its empty macrocells.
struct CastingVolume {
  CastingVolume(const VolumeObject& object, const MacrocellGrid& grid, float step, const ClipPlanes& clip);
  const Volume* volume;
  Box3 box;
  // The box, and for a pyramid's opened level its finest level's too: what particle AO's density grid
  // covers, so that its cells lie as they do over the finest level in memory.
  Box3 extent;
  TransferLut lut;
  const MacrocellGrid* grid;
  std::vector<std::uint8_t> empty;
  bool achromatic;
  ClipPlanes clip;  // the scene's clip planes when the volume is clipped, else none
  // A box of a finer level of the same volume (same voxel type), classified where a segment's midpoint
  // lies in it; null when the volume is not refined.
  std::shared_ptr<const CastingVolume> finer;

  // The part [t0, t1] of r within [tmin, tmax] inside the box and kept by the clip planes.
  bool span(const Ray& r, float& t0, float& t1, float tmin, float tmax) const {
    return box.clip(r, t0, t1, tmin, tmax) && clip.keep(r, t0, t1);
  }
};

// The spheres that cast: the first `count` spheres of the frame's particle set (the renderer puts
// casting particle objects first, so a sphere's index is the same in both).
struct CastingSpheres {
  const ParticleSet* set = nullptr;
  const SphereBvh* bvh = nullptr;  // null when no technique traces rays through spheres
  Box3 bounds;
  const SphereOrder* order = nullptr;  // the set's spatial order (null: a splat computes its own)
};

// How far off an isosurface of voxels `spacing` its shadow rays start (a twentieth of the smallest
// side): far enough that float rounding of a point at hundreds of voxels from the origin cannot put the
// start behind its own surface; small against any feature. The light pass's crease bias is twice it.
inline float isosurface_offset(const Vec3& spacing) { return 0.05f * std::min({spacing.x, spacing.y, spacing.z}); }

struct CastingIsosurface {
  const IsosurfaceRaycaster* raycaster;
  const GridTree* tree;
  float isovalue;
  std::uint32_t object;  // index into Scene::isosurfaces
  float offset;          // shadow rays start this far off the surface (a twentieth of a voxel)
  Box3 bounds;
  ClipPlanes clip;       // the scene's clip planes when the isosurface is clipped, else none
  // A refined box of the same surface (render/view_refinement.h): inside `finer_box` the light pass
  // extracts its points from `finer.tree` and shadow rays find the surface with `finer.raycaster`,
  // outside it from `tree` and with `raycaster`. Null when the surface has none.
  struct Finer {
    const IsosurfaceRaycaster* raycaster = nullptr;
    const GridTree* tree = nullptr;
  } finer;
  Box3 finer_box;
};

class ShadowCasters {
public:
  // The scene's casting volumes (grids[i] is the macrocell grid of scene.volumes[i]; null for volumes
  // that are not drawn) and planes. Spheres and isosurfaces are added by the renderer.
  // `finer[i]`, where given, is a refined box of scene.volumes[i] with its macrocells: that volume casts
  // from it where it lies, and the lattice is as fine as its voxel.
  struct FinerBox {
    const VolumeObject* object = nullptr;
    const MacrocellGrid* grid = nullptr;
  };
  ShadowCasters(const Scene& scene, std::span<const MacrocellGrid* const> grids, std::span<const FinerBox> finer = {});
  void set_spheres(const CastingSpheres& spheres);
  // `finer`: the surface over a refined box of the same volume (CastingIsosurface::finer), if any.
  void add_isosurface(const IsosurfaceRaycaster& raycaster, const GridTree& tree, std::uint32_t object,
                      const ClipPlanes& clip = ClipPlanes(), CastingIsosurface::Finer finer = {});

  // A copy holding only the casters of the given kinds (what one technique covers).
  ShadowCasters restricted_to(KindMask kinds) const;

  bool has_volume() const { return !volumes_.empty(); }
  float step() const { return step_; }            // Δ, world units
  const Box3& bounds() const { return bounds_; }  // what light frusta are fitted to
  const std::vector<Plane>& planes() const { return planes_; }
  const CastingSpheres& spheres() const { return spheres_; }
  const std::vector<std::shared_ptr<const CastingVolume>>& volumes() const { return volumes_; }
  const std::vector<CastingIsosurface>& isosurfaces() const { return isosurfaces_; }

  // Ray parameter of the nearest opaque caster (plane, sphere, isosurface) in (t0, t1), or infinity.
  // `finer_surfaces`: isosurfaces with a refined box are hit there on its surface (CastingIsosurface::finer;
  // false: on the opened level's everywhere, as a preview draws them).
  float surface_hit(const Ray& r, float t0, float t1, bool finer_surfaces = true) const;

  // Visits the volume segments of r inside [t_begin, t_end] in order (lattice k·Δ from the ray
  // origin), skipping space that is empty in every volume; visit(segment) returns false to stop.
  // In a copy restricted to a brick, only the segments the brick owns (their midpoints in its slab).
  template <class Visit>
  void march(const Ray& r, float t_begin, float t_end, Visit&& visit) const {
    if (!brick_) {
      march_lattice(r, t_begin, t_end, -kInfinity, visit);
      return;
    }
    // The lattice walk starts a step before the slab (its segments cut by the volume boxes only, the
    // same as in the whole volume's walk) and ends a step after it.
    float lo = -kInfinity, hi = kInfinity;
    if (!brick_->slab.clip(r, step_, lo, hi)) return;
    auto owned = [&](const MediumSegment& s) {
      if (s.t > hi) return false;
      return !brick_->slab.owns(r.at(s.t)) || visit(s);
    };
    march_lattice(r, t_begin, t_end, lo, owned);
  }

  // A copy whose march visits only the segments `brick` owns (for a technique that combines over
  // bricks); brick() is then set.
  ShadowCasters restricted_to_brick(const ShadowBrick& brick) const;
  const ShadowBrick* brick() const { return brick_ ? &*brick_ : nullptr; }

  // Exact transmittance along r over [t_begin, t_end] (the product of the colour model over all
  // segments, zero if an opaque caster is hit), stopping early below kShadowOpaque.
  Rgb transmittance(const Ray& r, float t_begin, float t_end, bool finer_surfaces = true) const {
    if (surface_hit(r, t_begin, t_end, finer_surfaces) < kInfinity) return Rgb(0.0f);
    Rgb T(1.0f);
    march(r, t_begin, t_end, [&](const MediumSegment& s) {
      T *= Rgb(1.0f) - (Rgb(1.0f) - s.transmission) * s.alpha;
      return T.max_component() > kShadowOpaque;
    });
    return T;
  }

  // The start of an exact shadow ray from a surface point: off the surface by the caster's own
  // offset (a thousandth of a sphere's radius, a twentieth of a voxel for isosurfaces, the scene's
  // epsilon for planes), to the side of `towards`.
  Vec3 ray_origin(const SurfacePoint& p, const Vec3& towards) const;
  float epsilon() const { return epsilon_; }  // 1e-4 of the bounds' radius

  // The extinction SAT of the visible volume, attached by the renderer for the techniques that need it.
  void attach_extinction_sat(const ExtinctionSat* sat) { sat_ = sat; }
  const ExtinctionSat& extinction_sat() const;  // throws Error when none is attached (no volume)

private:
  void update_bounds();

  // The lattice segments inside [t_begin, t_end], from the one holding t_from on.
  template <class Visit>
  void march_lattice(const Ray& r, float t_begin, float t_end, float t_from, Visit& visit) const {
    if (volumes_.size() == 1) march_one(*volumes_.front(), r, t_begin, t_end, t_from, visit);
    else if (!volumes_.empty()) march_many(r, t_begin, t_end, t_from, visit);
  }

  // Segment k of the lattice, [kΔ, (k+1)Δ], cut to [t0, t1] (only the first and last are cut); false
  // once it starts past t1.
  bool lattice_segment(std::int64_t k, float t0, float t1, float& seg0, float& seg1) const {
    const float lo = static_cast<float>(k) * step_, hi = lo + step_;
    seg0 = lo < t0 ? t0 : lo;
    seg1 = hi > t1 ? t1 : hi;
    return seg0 < t1;
  }
  // The opacity of a part of length `len` of a segment whose full opacity is `a`.
  float part_opacity(float a, float len) const {
    return len >= step_ * 0.9999f ? a : 1.0f - std::pow(1.0f - a, len / step_);
  }

  // One volume: the voxel type is decided once per ray, so that sampling inlines in the loop.
  template <class Visit>
  void march_one(const CastingVolume& cv, const Ray& r, float t_begin, float t_end, float t_from, Visit& visit) const {
    cv.volume->with_voxel_type([&](auto type) {
      float f0 = 0, f1 = 0;
      if (cv.finer && cv.finer->box.clip(r, f0, f1, t_begin, t_end))
        march_one_as<decltype(type), true>(cv, r, t_begin, t_end, t_from, f0, f1, visit);
      else
        march_one_as<decltype(type), false>(cv, r, t_begin, t_end, t_from, 0, 0, visit);
    });
  }
  // kFiner: the ray crosses cv.finer's box over [f0, f1]; a segment whose midpoint lies there is
  // classified in the box (empty space is skipped in each by its own cells, never past the other's start).
  template <class T, bool kFiner, class Visit>
  void march_one_as(const CastingVolume& cv, const Ray& r, float t_begin, float t_end, float t_from, float f0, float f1,
                    Visit& visit) const {
    float t0, t1;
    if (!cv.span(r, t0, t1, t_begin, t_end)) return;
    const EmptySpaceSkipper skipper(*cv.volume, *cv.grid, cv.empty);
    const CastingVolume* finer = kFiner ? cv.finer.get() : nullptr;
    const std::optional<EmptySpaceSkipper> finer_skipper =
        kFiner ? std::optional<EmptySpaceSkipper>(std::in_place, *finer->volume, *finer->grid, finer->empty) : std::nullopt;
    std::size_t last_cell = SIZE_MAX;
    bool last_in_finer = false;
    std::int64_t k = static_cast<std::int64_t>(std::floor(std::max(t0, t_from) / step_));
    while (true) {
      float seg0, seg1;
      if (!lattice_segment(k, t0, t1, seg0, seg1)) return;
      if (seg1 <= seg0) { ++k; continue; }
      const float tm = 0.5f * (seg0 + seg1);
      const Vec3 p = r.at(tm);
      const bool in_finer = kFiner && tm >= f0 && tm <= f1;
      const CastingVolume& at = in_finer ? *finer : cv;
      const EmptySpaceSkipper& sk = in_finer ? *finer_skipper : skipper;
      const Vec3 v = at.volume->to_voxel(p);
      const TrilinearCell tc = at.volume->trilinear_cell(v);  // shared by the macrocell and the value
      const std::size_t cell = sk.cell_of(tc);
      if (cell != last_cell || in_finer != last_in_finer) {
        last_cell = cell;
        last_in_finer = in_finer;
        if (sk.empty(cell)) {  // empty cell: continue with the segment that holds the cell's exit
          float t_skip = sk.cell_exit(r, tm, v);
          if (kFiner) t_skip = in_finer ? std::min(t_skip, f1) : tm < f0 ? std::min(t_skip, f0) : t_skip;
          k = std::max(k + 1, static_cast<std::int64_t>(std::floor(t_skip / step_)));
          last_cell = SIZE_MAX;
          continue;
        }
      }
      const Rgba s = at.lut.lookup(at.volume->template sample_cell_as<T>(tc));
      if (s.a > 0) {
        const float a = part_opacity(s.a, seg1 - seg0);
        if (!visit(MediumSegment{k, tm, seg0, seg1, a, cv.achromatic ? Rgb(0.0f) : s.rgb})) return;
      }
      ++k;
    }
  }

  // Overlapping volumes: the segment's midpoint is classified in every volume that holds it; space
  // is skipped only where every volume is empty (or absent).
  template <class Visit>
  void march_many(const Ray& r, float t_begin, float t_end, float t_from, Visit& visit) const {
    float t0 = kInfinity, t1 = -kInfinity;
    for (const auto& cv : volumes_) {
      float a, b;
      if (cv->span(r, a, b, t_begin, t_end)) {
        t0 = std::min(t0, a);
        t1 = std::max(t1, b);
      }
    }
    if (!(t0 <= t1)) return;
    std::int64_t k = static_cast<std::int64_t>(std::floor(std::max(t0, t_from) / step_));
    while (true) {
      float seg0, seg1;
      if (!lattice_segment(k, t0, t1, seg0, seg1)) return;
      if (seg1 <= seg0) { ++k; continue; }
      const float tm = 0.5f * (seg0 + seg1);
      const Vec3 p = r.at(tm);
      Rgb pass(1.0f);
      float clear = 1;         // Π(1 − α_v)
      float skip_to = kInfinity;  // where the next non-empty space may start
      bool occupied = false;
      const float len = seg1 - seg0;
      for (const auto& cvp : volumes_) {
        const CastingVolume& cv = *cvp;
        float a0, a1;
        if (!cv.span(r, a0, a1, tm, t1)) continue;  // behind p, missed or cut away
        if (a0 > tm) {  // ahead: its box starts later
          skip_to = std::min(skip_to, a0);
          continue;
        }
        // inside a refined box the segment is classified there; before it, never skipped past its start
        float f0 = 0, f1 = 0;
        const bool crosses_finer = cv.finer && cv.finer->box.clip(r, f0, f1, tm, t1);
        const bool in_finer = crosses_finer && f0 <= tm;
        const CastingVolume& at = in_finer ? *cv.finer : cv;
        if (crosses_finer && !in_finer) skip_to = std::min(skip_to, f0);
        const Vec3 v = at.volume->to_voxel(p);
        const EmptySpaceSkipper skipper(*at.volume, *at.grid, at.empty);
        const std::size_t cell = skipper.cell_of(v);
        if (skipper.empty(cell)) {
          const float exit = skipper.cell_exit(r, tm, v);
          skip_to = std::min(skip_to, in_finer ? std::min(exit, f1) : exit);
          continue;
        }
        occupied = true;
        const Rgba s = at.lut.lookup(at.volume->sample_voxel(v));
        if (s.a <= 0) continue;
        const float a = part_opacity(s.a, len);
        pass *= Rgb(1.0f) - (Rgb(1.0f) - (at.achromatic ? Rgb(0.0f) : s.rgb)) * a;
        clear *= 1 - a;
      }
      if (!occupied) {
        if (skip_to == kInfinity) return;
        k = std::max(k + 1, static_cast<std::int64_t>(std::floor(skip_to / step_)));
        continue;
      }
      const float alpha = 1 - clear;
      if (alpha > 0) {
        const Rgb transmission = Rgb(1.0f) - (Rgb(1.0f) - pass) * (1.0f / alpha);
        if (!visit(MediumSegment{k, tm, seg0, seg1, alpha, transmission})) return;
      }
      ++k;
    }
  }

  std::vector<std::shared_ptr<const CastingVolume>> volumes_;
  std::vector<Plane> planes_;  // the casting planes
  CastingSpheres spheres_;
  std::vector<CastingIsosurface> isosurfaces_;
  Box3 bounds_;
  float step_ = 1;
  float epsilon_ = 1e-4f;
  const ExtinctionSat* sat_ = nullptr;
  std::optional<ShadowBrick> brick_;
};

}  // namespace penumbra
