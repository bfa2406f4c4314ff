// A point on an opaque surface, as shading and the shadow and ambient techniques see it: position,
// normal, and which object it lies on, so that nothing shadows itself — a sphere is never its own
// occluder (ISSM skips it by identity, rays start off it), a plane cannot shadow itself, and an
// isosurface point carries how far from the true surface it may lie.
#pragma once

#include <cstdint>

#include "penumbra/core/math.h"
#include "penumbra/data/particles.h"
#include "penumbra/scene/scene.h"

namespace penumbra {


struct SurfacePoint {
  Vec3 position;
  Vec3 normal;                          // unit, facing the viewer
  std::uint32_t self = kNoSphere;       // spheres: the sphere's index in the frame's particle set
  ObjectKind kind = ObjectKind::Plane;  // Spheres, Isosurface or Plane
  std::uint32_t object = 0;             // index of the particle object, isosurface or plane
  float error = 0;                      // isosurfaces: how far from the surface the point may lie
};

}  // namespace penumbra
