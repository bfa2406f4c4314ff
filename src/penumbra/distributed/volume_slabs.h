// Sort-last, data-parallel volume rendering (DESIGN.md "Built to scale"; the compositing of IceT and
// of OSPRay's MPI module): a volume is split along z into slabs of whole voxel slices, one per brick,
// each brick ray casts only the samples it owns (render/volume_raycaster.h, SampleSlab: every sample of
// a ray's lattice in exactly one brick) into premultiplied colour and opacity over black, and the
// bricks' images are composited per pixel in the order its ray crosses them ("over", front to back).
//
// This is the step a distributed frame runs on every rank; here it also runs as a brick loop in one
// process (`penumbra render --slabs N`), which checks the decomposition against the whole-volume
// frame. What it does not yet do: shadows and ambient occlusion across bricks (each brick is shaded
// unshadowed), surfaces (spheres, isosurfaces, planes) in the bricked scene, reading only a brick's
// voxels from disk.
//
// | parameter | meaning                                                             |
// | count     | slabs (bricks); at most the volume's voxel slices along z             |
#pragma once

#include <span>
#include <vector>

#include "penumbra/core/image.h"
#include "penumbra/data/volume.h"
#include "penumbra/render/volume_raycaster.h"
#include "penumbra/scene/camera.h"

namespace penumbra {

// Slab b holds the voxel slices [nz·b/count, nz·(b+1)/count) and owns the samples between the world z
// halfway to the slices beside it (the first from −∞, the last to +∞). Throws Error when count < 1 or
// count exceeds the slices.
std::vector<SampleSlab> volume_slabs(const Volume& volume, int count);

// One brick's frame: its samples' colour (premultiplied, rendered over black) and opacity per pixel.
struct BrickImage {
  const Image* color;
  std::span<const float> opacity;
};

// The bricks (in slab order, z increasing) composited front to back along each pixel's primary ray,
// over `background`: C = Σ_b (Π_{b' before b} (1 − A_b')) C_b, plus the transmittance left times the
// background.
Image composite_slabs(std::span<const BrickImage> bricks, const Camera& camera, const Rgb& background);

}  // namespace penumbra
