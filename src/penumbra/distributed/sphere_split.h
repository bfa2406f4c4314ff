// A particle scene split by space over the ranks of a data-parallel frame (distributed_frame.h): the
// spheres of every particle object, ordered by the z of their centres, are cut into `ranks` runs of
// equal count (a z-order split: each rank's spheres fill a slab of z, and the ranks' loads match however
// the atoms crowd); rank r keeps run r. Every rank renders its spheres — with the planes, which all of
// them hold — into colour and depth, and the frames are composited by depth (the nearest surface shows).
// Shadows and occlusion cross the ranks: the implicit sphere shadow map keeps the nearest candidate of
// every rank per texel, the CSSM the nearest first stop, and the particle ambient occlusion sums the
// ranks' densities; every rank fits its maps to the box of all the spheres
// (accel/brick_reduction.h), so a sphere on one rank shadows a sphere on another.
//
// Beside a volume split into slabs, a rank holds the spheres that reach into its slab (their z extent
// overlaps it: a sphere across a slab face is held by both ranks) and shows those whose visible point
// lies in its slab; the ISSM's nearest candidate is the same for a sphere two ranks hold, and the
// particle AO splats a sphere on the rank whose slab owns its centre, so none counts twice.
//
// | parameter | meaning                                                     |
// | ranks     | MPI ranks: runs of spheres, one per rank (1 … the spheres)   |
#pragma once

#include <cstddef>
#include <string>

#include "penumbra/core/sample_slab.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

// Whether a frame of the scene splits its spheres: it has spheres and no volume (a volume's slabs split
// the frame otherwise, every rank holding every sphere).
bool splits_spheres(const Scene& scene);

// Throws Error unless a frame of the scene can be split over ranks: it holds a volume or spheres.
void check_splittable(const Scene& scene);

// Throws Error unless the scene's spheres can be split: their shadows must be the implicit sphere shadow
// map or the CSSM (or none), their ambient occlusion particle_ao (or none), and there must be at least
// as many spheres as ranks. Every message names the key and what it expects.
void check_spheres_split(const Scene& scene, int ranks);

// "" when every rank can hold only the spheres that reach into its slab of the scene's volume; else why
// every rank holds them all (sphere shadows other than issm and cssm, ambient occlusion other than particle_ao
// or the extinction SAT's, or the extinction SAT, which the casting spheres enter whole).
std::string why_spheres_whole(const Scene& scene);

struct SphereShare {
  Scene scene;       // the scene with this rank's spheres only (each object keeps its spheres in file order)
  std::size_t spheres = 0;  // how many
  SampleSlab slab;   // the z of its first and last centre (for --stats)
};

// Rank `rank`'s share of the scene's spheres (no volume: a run in z order).
SphereShare sphere_share(const Scene& scene, int ranks, int rank);
// The spheres whose z extent overlaps `slab` (beside a volume); SphereShare::slab is `slab`.
SphereShare spheres_in_slab(const Scene& scene, const SampleSlab& slab);

}  // namespace penumbra
