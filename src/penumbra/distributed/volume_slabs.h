// Sort-last, data-parallel volume rendering (DESIGN.md "Built to scale"; the compositing of IceT and
// of OSPRay's MPI module): a volume is split along z into slabs of whole voxel slices, one per brick,
// each brick ray casts only the samples it owns (render/volume_raycaster.h, SampleSlab: every sample of
// a ray's lattice in exactly one brick) into premultiplied colour and opacity over black, and the
// bricks' images are composited per pixel in the order its ray crosses them ("over", front to back).
//
// This is the step a distributed frame runs on every rank; here it runs as a brick loop in one
// process (render_in_slabs, `penumbra render --slabs N`), which checks the decomposition against the
// whole-volume frame. Each slab's renderer holds the whole scene, so its shadows and ambient occlusion
// are the whole volume's (on MPI ranks the structures that combine over bricks are built per brick,
// distributed_frame.h, and each rank reads only its brick, brick_reading.h). Opaque surfaces (planes,
// spheres, isosurfaces) are held whole by every slab, which shows those whose visible point it holds.
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
#include "penumbra/scene/scene.h"

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

// One pixel of the bricks (in slab order, z increasing) composited front to back along its primary ray,
// over `background`: C = Σ_b (Π_{b' before b} (1 − A_b')) C_b, plus the transmittance left times the
// background. brick(b) gives slab b's premultiplied colour and opacity there; `downwards`: the ray's
// direction has z < 0, so it meets the slabs from the last to the first.
template <class BrickAt>
Rgb composite_pixel(std::size_t bricks, bool downwards, const Rgb& background, BrickAt&& brick) {
  Rgb color(0.0f);
  float transmittance = 1;
  for (std::size_t k = 0; k < bricks; ++k) {
    const auto [c, a] = brick(downwards ? bricks - 1 - k : k);
    color += c * transmittance;
    transmittance *= 1 - a;
  }
  return color + background * transmittance;
}

// Every pixel so composited (the brick loop's compositing).
Image composite_slabs(std::span<const BrickImage> bricks, const Camera& camera, const Rgb& background);

// Throws Error unless the scene holds a volume: its first volume's slabs split the frame. Opaque surfaces
// (planes, spheres, isosurfaces) are held whole by every brick, which shows those whose visible point
// lies in its slab (FrameRequest::slab).
void check_has_volume(const Scene& scene);

// The brick loop: the scene's first volume split into `count` slabs, each rendered alone over black at
// full quality, composited over the scene's background. Throws Error for a scene without a volume, or
// for count outside 1 … the volume's slices.
struct SlabFrame {
  Image image;
  std::vector<SampleSlab> slabs;
  std::vector<double> render_ms;  // per slab
  double composite_ms = 0;
};
SlabFrame render_in_slabs(const Scene& scene, int count);

}  // namespace penumbra
