// A data-parallel frame on MPI ranks (`mpirun -np N penumbra render`): sort-last rendering with
// direct-send compositing, the scheme of IceT's and OSPRay's MPI compositors.
//
// 1. Rank r takes slab r of the scene's volume (distributed/volume_slabs.h: every sample of a ray's
//    lattice in exactly one slab) and ray casts only the samples it owns, into premultiplied colour
//    and opacity over black.
// 2. Direct send: the image is cut into N bands of rows; rank r owns band r, and every rank sends each
//    band's part of its active rectangle (the pixels its samples touched; IceT's bounding boxes) as
//    RGBA floats to the band's owner (an all-gather of the rectangles, then one all-to-all).
// 3. Each rank composites its band's N layers along each pixel's ray (composite_pixel, the brick loop's
//    arithmetic: the frame is bit for bit `render --slabs N`), over the scene's background.
// 4. Rank 0 gathers the bands (RGB floats) into the image.
// With `--compositor icet` (or icet-bswap) steps 2–4 are IceT's instead (distributed/icet_compositor.h):
// radix-k or binary swap over the ranks' active rectangles, the same "over" in visibility order.
//
// A scene of spheres without a volume is split by space instead (distributed/sphere_split.h): each
// rank renders its share of the spheres and the planes into colour and depth, sends RGB and depth, and
// the bands are composited by depth (the nearest surface shows). Beside a volume, a rank holds the
// spheres that reach into its slab (all of them when their techniques do not combine over ranks).
//
// Shadows across ranks: the light structures that combine over bricks (accel/brick_reduction.h: the
// CSSM by the per-channel minimum, the classic shadow map from the transparency in front and the
// nearest crossing, the deep shadow map by products and a compression over the ranks, the extinction
// SAT by sums; the isosurface light pass, each rank extracting from its brick's cells, by its frustum
// fitted to every rank's receivers, holes punched by any rank and the nearest depth per light pixel;
// for split spheres the implicit sphere shadow map by the nearest candidate and the particle AO by
// sums) are built by each rank from what it owns and reduced across the ranks, so an occluder on one
// rank shadows a receiver on another, as in one process. The others (ray-traced shadows and AO) are
// built by every rank from the whole volume, which every rank then reads (distributed/brick_reading.h).
//
// Bytes sent per frame and rank: the CSSM reduction, resolution² × 3 floats per round of the
// allreduce (⌈log2 N⌉ rounds in recursive doubling; the classic map resolution² floats a round for its
// scan and as many for its minimum); in the exchange the other ranks' bands of its
// active rectangle, 4 floats a pixel (at most (N−1)/N of the W×H image); its band's W×H/N×3 floats to
// rank 0.
//
// | parameter | meaning                                                        |
// | ranks     | MPI ranks: slabs, one per rank (1 … the volume's slices along z) |
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "penumbra/core/image.h"
#include "penumbra/distributed/icet_compositor.h"
#include "penumbra/distributed/mpi_world.h"
#include "penumbra/render/volume_raycaster.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

class Renderer;

// What one rank did in a frame (every rank's, gathered on rank 0).
struct RankFrameStats {
  SampleSlab slab;              // a volume's: the samples the rank owns; split spheres: its centres' z
  std::optional<std::size_t> spheres;  // split spheres: how many the rank holds (unset: every sphere)
  double prepare_ms = 0, build_ms = 0, render_ms = 0;  // the rank's FrameResult times
  double composite_ms = 0;      // direct send: compositing its band (after the exchange); IceT: its ICET_COMPOSITE_TIME
  double compositing_ms = 0;    // the whole compositing step, exchange and gather included (from the end of its
                                // render, so a rank that finished first also waits for the slowest there)
  // in MPI calls (reductions, exchange, gather, agreement), waiting included, and bytes sent in all: since
  // the renderer's previous frame (the first frame: since the renderer was made, its split included)
  double communication_ms = 0;
  double bytes_sent = 0;
  double shadow_bytes_sent = 0; // combining the light structures built per brick
  double image_bytes_sent = 0;  // direct send and the gather of the bands
  std::size_t structures_rebuilt = 0;  // the rank renderer's structures rebuilt for this frame (none: all kept)
};

struct DistributedFrame {
  Image image;                         // rank 0: the frame over the scene's background; others: empty
  std::vector<RankFrameStats> ranks;   // rank 0: every rank's, in rank order; others: empty
  std::vector<std::string> rebuilt;    // rank 0: the structures its renderer rebuilt (Structures names)
};

// This rank's part of a data-parallel renderer, kept across the frames of a sequence: the scene's split
// (its slab, or its share of the spheres) and a Renderer holding the rank's share, whose structures stay
// while what they depend on stays, as in one process (render/renderer.h). A new camera keeps every light
// structure (an orbit renders each later frame without rebuilding), a new light rebuilds that light's
// shadows only, reduced across the ranks again; new data (a time step) takes a new DistributedRenderer.
//
// The constructor splits the scene; every rank calls it with the same scene. Throws Error on every rank
// alike (the lowest failing rank's message, MpiWorld::agree) when the scene cannot be split (neither a
// volume nor spheres, more ranks than voxel slices or spheres, a particle scene whose sphere shadows are
// not issm or cssm).
class DistributedRenderer {
public:
  DistributedRenderer(const Scene& scene, MpiWorld& world, Compositor compositor = Compositor::direct_send);
  ~DistributedRenderer();
  DistributedRenderer(const DistributedRenderer&) = delete;
  DistributedRenderer& operator=(const DistributedRenderer&) = delete;

  // Renders a frame with this camera and these lights (the same on every rank) across the ranks. A rank
  // whose render fails (its light structures reduce across the ranks inside it, where the others may be
  // waiting) stops every rank with its message (MpiWorld::abort); on one rank the Error is thrown.
  DistributedFrame render(const Camera& camera, const std::vector<Light>& lights);

private:
  struct Composited {
    Image image;  // rank 0's
    double composite_ms = 0;
  };
  // Steps 2–4 by direct send: this rank's layer and active rectangle {x0, y0, x1, y1} to the band owners.
  Composited composite_by_direct_send(const FrameResult& frame, const Camera& camera, const int (&active)[4]);
  // The ranks in the order a primary ray from this camera's eye meets their slabs (IceT's composite order).
  std::vector<int> visibility_order(const Camera& camera) const;

  MpiWorld& world_;
  Rgb background_;
  bool by_depth_ = false;                 // spheres split by space, composited by depth
  SampleSlab slab_;                       // a volume's: the samples this rank owns; split spheres: its centres' z
  std::vector<SampleSlab> slabs_;         // a volume's: every rank's, in rank order
  std::unique_ptr<IcetCompositor> icet_;  // --compositor icet…: IceT's context (unset: direct send)
  std::optional<std::size_t> spheres_;    // the spheres this rank holds, when split (unset: every sphere)
  std::unique_ptr<Renderer> renderer_;
  double communication_mark_;             // the world's counters when the last frame's figures were taken
  std::size_t bytes_mark_;
};

// One frame of the scene (its camera and lights) across the world's ranks: a DistributedRenderer made
// and used once.
DistributedFrame render_distributed(const Scene& scene, MpiWorld& world, Compositor compositor = Compositor::direct_send);

}  // namespace penumbra
