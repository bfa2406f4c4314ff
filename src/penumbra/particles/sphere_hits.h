// The sphere renderer's visibility buffer: per pixel, the nearest sphere along the primary ray (its id)
// and the distance to it. Two ways to fill it, both pixel-exact (each covered pixel intersects its own
// primary ray with the sphere): splatting every sphere's screen-space bounding rectangle into the
// buffer tile by tile (the CPU form of GPU sphere impostors, Falk et al. 2016), or one
// Embree ray per pixel. `penumbra bench --suite particles` compares them.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "penumbra/data/particles.h"
#include "penumbra/geometry/sphere_bvh.h"
#include "penumbra/geometry/sphere_order.h"
#include "penumbra/scene/camera.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

struct SphereHits {
  int width = 0, height = 0;
  std::vector<float> t;           // distance along the unit primary ray; infinity where no sphere
  std::vector<std::uint32_t> id;  // kNoSphere where no sphere

  std::size_t covered() const;    // pixels showing a sphere
};


// Tile-binned splatting: every sphere's projected bounding rectangle (exact per axis for a sphere in
// front of the camera) is binned into 32×32-pixel screen tiles; each tile then walks its spheres, and
// each pixel of a rectangle intersects its primary ray with the sphere, keeping the nearest hit (ties
// to the lower id, so the result does not depend on the order of the bins).
// The spheres are walked in `order` (geometry/sphere_order.h; the result does not depend on it); without one,
// the set's spatial order is computed first.
SphereHits splat_spheres(const ParticleSet& particles, const SphereOrder& order, const Camera& camera);
SphereHits splat_spheres(const ParticleSet& particles, const Camera& camera);

// One Embree ray per pixel.
SphereHits trace_spheres(const SphereBvh& bvh, const Camera& camera);

}  // namespace penumbra
