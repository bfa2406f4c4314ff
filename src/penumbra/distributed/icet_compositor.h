// Sort-last image compositing through IceT, the field's compositing library (Moreland, Kendall, Peterka
// and Huang, "An Image Compositing Solution at Scale", SC 2011; radix-k: Peterka, Goodell, Ross, Shen
// and Thakur, SC 2009; binary swap: Ma, Painter, Hansen and Krogh, IEEE CG&A 1994) — the optional
// backend of a data-parallel frame (`mpirun … penumbra render --compositor icet`), beside penumbra's own
// direct send (distributed_frame.cpp), which needs nothing.
//
// Each rank hands IceT its layer over black and its active rectangle (IceT's valid pixels; the rest of
// its layer is ignored), and rank 0 gets the image:
// - a volume's slab: premultiplied RGBA floats blended "over" (ICET_COMPOSITE_MODE_BLEND) in one
//   visibility order for the whole frame (ICET_ORDERED_COMPOSITE). The slabs are z intervals and every
//   primary ray starts at the eye, so the slab holding the eye comes first, then the slabs above and
//   below it alternately, each side outwards: a ray going up never enters the slabs below the eye's,
//   whose layers are transparent black on its pixel, so that order is every pixel's order;
// - split spheres: RGBA with alpha 1 where a surface shows, and the depth (ICET_COMPOSITE_MODE_Z_BUFFER,
//   the nearest shows). IceT wants depths in [0, 1] with 1 for the background: the distances are scaled
//   by a power of two (exact, so their order is kept) that brings the ranks' largest below 1.
// IceT blends in its own order of operations (a reduction tree), so its frame equals direct send's up
// to float rounding, not bit for bit (docs/distributed.md measures it).
//
// | parameter | meaning                                                                        |
// | strategy  | IceT's single-image strategy: radix-k (`icet`, IceT's default) or binary swap (`icet-bswap`) |
#pragma once

#include <memory>
#include <span>
#include <string>

#include "penumbra/core/image.h"
#include "penumbra/distributed/mpi_world.h"

namespace penumbra {

struct FrameResult;

enum class Compositor { direct_send, icet_radixk, icet_bswap };

// "direct-send", "icet" (radix-k) or "icet-bswap"; Error naming the value and the choices otherwise, and
// for an IceT strategy when this penumbra was built without IceT (scripts/fetch-icet.sh).
Compositor parse_compositor(const std::string& name);
std::string compositor_name(Compositor compositor);
// Whether this penumbra was built with IceT.
bool icet_built();

// One IceT context over MPI_COMM_WORLD, made by every rank alike and kept across frames.
class IcetCompositor {
public:
  explicit IcetCompositor(Compositor strategy);  // an IceT strategy; Error when built without IceT
  ~IcetCompositor();
  IcetCompositor(const IcetCompositor&) = delete;
  IcetCompositor& operator=(const IcetCompositor&) = delete;

  struct Result {
    Image image;             // rank 0: the frame over `background`; others: empty
    double composite_ms = 0; // IceT's ICET_COMPOSITE_TIME (its exchange and blending)
    double bytes_sent = 0;   // IceT's ICET_BYTES_SENT, this rank's
  };
  // Every rank calls it with its layer (frame.image premultiplied over black, frame.alpha; by depth:
  // frame.depth), its active rectangle {x0, y0, x1, y1} (top-down rows, half open; empty: nothing) and,
  // blending, `order`: the ranks front to back. By depth the ranks first agree on the depth scale (a
  // minimum over `world`).
  Result composite(const FrameResult& frame, const int (&active)[4], bool by_depth, std::span<const int> order, const Rgb& background,
                   MpiWorld& world);

private:
  struct Context;
  std::unique_ptr<Context> context_;
};

}  // namespace penumbra
