// The frame's spheres against the scene's clip planes (core/clip_planes.h): each sphere of a clipped
// particle object is marked whole, removed or cut (the planes crossing it), so that the eye pass, the
// BVH and every light structure see the same kept parts (geometry/cut_sphere.h).
#pragma once

#include <cstdint>
#include <span>
#include <vector>

#include "penumbra/data/particles.h"

namespace penumbra {

// `set` holds the objects' spheres one after another: object k's are [offsets[k], offsets[k + 1]),
// clipped when clipped[k]. Clears the marks when no object is clipped or there are no planes.
void clip_spheres(ParticleSet& set, const ClipPlanes& planes, std::span<const std::uint32_t> offsets,
                  const std::vector<bool>& clipped);

}  // namespace penumbra
