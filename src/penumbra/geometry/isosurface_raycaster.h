// The exact isosurface reference: the first root of the trilinear interpolant along each ray (Parker et
// al., "Interactive ray tracing for isosurface rendering", Visualization 1998, the method paper 002
// compares its points against). A ray walks the GridTree front to back — at each level a 3D-DDA
// (Amanatides & Woo 1987) over the children of a node that may hold the isovalue, skipping every node
// whose range cannot — and in a brick a DDA over its cells calls first_state_change (trilinear_root.h)
// for the cells whose corners straddle the isovalue.
//
// The traversal carries the inside state from cell to cell: a cell whose own start state differs from
// the state where the ray left the previous one reports a crossing at its entry, so a crossing lying
// exactly on a cell face, or at the edge of a pruned node, is never lost to rounding. The state at the
// ray's start is that of the first cell it meets; a ray entering the volume inside the surface
// therefore reports where it leaves, as marching cubes (which puts no faces on the volume's border)
// would draw it.
#pragma once

#include "penumbra/core/clip_planes.h"
#include "penumbra/geometry/grid_tree.h"
#include "penumbra/geometry/iso_point.h"
#include "penumbra/scene/camera.h"

namespace penumbra {

class IsosurfaceRaycaster {
public:
  IsosurfaceRaycaster(const GridTree& tree, float isovalue) : tree_(&tree), isovalue_(isovalue) {}

  // The first crossing of the isosurface in (tmin, tmax] (the ray clipped to the volume's cells), or
  // kInfinity. An exact shadow ray: first_hit(Ray{p + n * eps, to_light}, 0, distance) < kInfinity.
  float first_hit(const Ray& ray, float tmin, float tmax) const;
  // The same with `finer`, this surface over a box of finer voxels (a refined view of a volume opened
  // coarse, render/view_refinement.h): this surface before the box's bounds, finer's inside them, this
  // one behind them. `met`: the ray caster whose surface the crossing lies on.
  float first_hit(const Ray& ray, float tmin, float tmax, const IsosurfaceRaycaster& finer, const IsosurfaceRaycaster** met = nullptr) const;

  // One point per pixel whose primary ray (PrimaryRays) hits, in pixel order (y, then x); the same for
  // any thread count. Normal: the normalized gradient turned to face the eye (-direction where the
  // gradient vanishes); distance: the ray parameter, i.e. from the eye. `clip`: planes that cut it;
  // `finer`: a refined box of the same surface, met inside its bounds (its voxels' gradient there).
  IsoPoints render(const Camera& camera, const ClipPlanes& clip = ClipPlanes(), const IsosurfaceRaycaster* finer = nullptr) const;

  float isovalue() const { return isovalue_; }

private:
  const GridTree* tree_;
  float isovalue_;
};

}  // namespace penumbra
