// A particle scene split by space over the ranks of a data-parallel frame (distributed_frame.h): the
// spheres of every particle object, ordered by the z of their centres, are cut into `ranks` runs of
// equal count (a z-order split: each rank's spheres fill a slab of z, and the ranks' loads match however
// the atoms crowd); rank r keeps run r. Every rank renders its spheres — with the planes, which all of
// them hold — into colour and depth, and the frames are composited by depth (the nearest surface shows).
// Shadows and occlusion cross the ranks: the implicit sphere shadow map keeps the nearest candidate of
// every rank per texel, and the particle ambient occlusion sums the ranks' densities
// (shadows/shadow_brick.h), so a sphere on one rank shadows a sphere on another.
//
// | parameter | meaning                                                     |
// | ranks     | MPI ranks: runs of spheres, one per rank (1 … the spheres)   |
#pragma once

#include <cstddef>

#include "penumbra/core/sample_slab.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

// Whether a frame of the scene splits its spheres: it has spheres and no volume (a volume's slabs split
// the frame otherwise, every rank holding every sphere).
bool splits_spheres(const Scene& scene);

// Throws Error unless a frame of the scene can be split over ranks: it holds a volume or spheres.
void check_splittable(const Scene& scene);

// Throws Error unless the scene's spheres can be split: their shadows must be the implicit sphere shadow
// map (or none), their ambient occlusion particle_ao (or none), and there must be at least as many
// spheres as ranks. Every message names the key and what it expects.
void check_spheres_split(const Scene& scene, int ranks);

struct SphereShare {
  Scene scene;       // the scene with this rank's spheres only (each object keeps its spheres in file order)
  std::size_t spheres = 0;  // how many
  SampleSlab slab;   // the z of its first and last centre (for --stats)
};

// Rank `rank`'s share of the scene's spheres.
SphereShare sphere_share(const Scene& scene, int ranks, int rank);

}  // namespace penumbra
