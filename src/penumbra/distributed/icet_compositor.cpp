#include "penumbra/distributed/icet_compositor.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <utility>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/render/renderer.h"

#ifdef PENUMBRA_HAVE_ICET
#define OMPI_SKIP_MPICXX 1  // the C API only (IceTMPI.h includes mpi.h)
#include <IceT.h>
#include <IceTMPI.h>
#endif

namespace penumbra {

namespace {

constexpr std::pair<Compositor, const char*> kCompositorNames[] = {
    {Compositor::direct_send, "direct-send"}, {Compositor::icet_radixk, "icet"}, {Compositor::icet_bswap, "icet-bswap"}};

}  // namespace

Compositor parse_compositor(const std::string& name) {
  const auto* found = std::find_if(std::begin(kCompositorNames), std::end(kCompositorNames), [&](const auto& c) { return name == c.second; });
  if (found == std::end(kCompositorNames))
    throw Error("--compositor " + name + ": expected direct-send, icet (radix-k) or icet-bswap (binary swap)");
  if (found->first != Compositor::direct_send && !icet_built())
    throw Error("--compositor " + name + ": this penumbra was built without IceT (run scripts/fetch-icet.sh, then cmake again)");
  return found->first;
}

std::string compositor_name(Compositor compositor) {
  return std::find_if(std::begin(kCompositorNames), std::end(kCompositorNames), [&](const auto& c) { return c.first == compositor; })->second;
}

#ifdef PENUMBRA_HAVE_ICET

bool icet_built() { return true; }

namespace {

const char* icet_error_name(IceTEnum error) {
  switch (error) {
    case ICET_SANITY_CHECK_FAIL: return "ICET_SANITY_CHECK_FAIL";
    case ICET_INVALID_ENUM: return "ICET_INVALID_ENUM";
    case ICET_BAD_CAST: return "ICET_BAD_CAST";
    case ICET_OUT_OF_MEMORY: return "ICET_OUT_OF_MEMORY";
    case ICET_INVALID_OPERATION: return "ICET_INVALID_OPERATION";
    case ICET_INVALID_VALUE: return "ICET_INVALID_VALUE";
    default: return "an unknown error";
  }
}

}  // namespace

struct IcetCompositor::Context {
  IceTCommunicator communicator;
  IceTContext context;
};

IcetCompositor::IcetCompositor(Compositor strategy) {
  if (strategy == Compositor::direct_send) throw Error("IcetCompositor: an IceT strategy is needed");
  IceTCommunicator communicator = icetCreateMPICommunicator(MPI_COMM_WORLD);
  context_ = std::make_unique<Context>(Context{communicator, icetCreateContext(communicator)});
  icetDiagnostics(ICET_DIAG_ERRORS | ICET_DIAG_ALL_NODES);
  icetStrategy(ICET_STRATEGY_REDUCE);
  icetSingleImageStrategy(strategy == Compositor::icet_bswap ? ICET_SINGLE_IMAGE_STRATEGY_BSWAP : ICET_SINGLE_IMAGE_STRATEGY_RADIXK);
}

IcetCompositor::~IcetCompositor() {
  icetDestroyContext(context_->context);
  icetDestroyMPICommunicator(context_->communicator);
}

IcetCompositor::Result IcetCompositor::composite(const FrameResult& frame, const int (&active)[4], bool by_depth, std::span<const int> order,
                                                 const Rgb& background, MpiWorld& world) {
  // by depth: a power of two that brings every rank's largest finite depth below 1 (IceT's far plane)
  float depth_scale = 1;
  if (by_depth) {
    float farthest[] = {0};  // its negative, for the minimum over the ranks
    for (const float d : frame.depth)
      if (std::isfinite(d)) farthest[0] = std::min(farthest[0], -d);
    world.minimum(farthest);
    depth_scale = std::ldexp(1.0f, -(std::ilogb(std::max(-farthest[0], 1.0f)) + 1));
  }
  icetSetContext(context_->context);
  const int width = frame.image.width(), height = frame.image.height();
  icetResetTiles();
  icetAddTile(0, 0, width, height, 0);  // one tile, shown by rank 0
  icetSetColorFormat(ICET_IMAGE_COLOR_RGBA_FLOAT);
  icetSetDepthFormat(by_depth ? ICET_IMAGE_DEPTH_FLOAT : ICET_IMAGE_DEPTH_NONE);
  icetCompositeMode(by_depth ? ICET_COMPOSITE_MODE_Z_BUFFER : ICET_COMPOSITE_MODE_BLEND);
  icetDisable(ICET_CORRECT_COLORED_BACKGROUND);  // the background is added below, on rank 0
  if (by_depth) {
    icetDisable(ICET_ORDERED_COMPOSITE);
  } else {
    icetEnable(ICET_ORDERED_COMPOSITE);
    const std::vector<IceTInt> ranks(order.begin(), order.end());
    icetCompositeOrder(ranks.data());
  }

  // IceT's rows go up from the bottom of the image
  const std::size_t pixels = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
  std::vector<IceTFloat> color(pixels * 4), depth(by_depth ? pixels : 0);
  parallel_for(static_cast<std::size_t>(height), [&](std::size_t y0, std::size_t y1) {
    for (std::size_t y = y0; y < y1; ++y)
      for (std::size_t x = 0; x < static_cast<std::size_t>(width); ++x) {
        const std::size_t p = y * static_cast<std::size_t>(width) + x;
        const std::size_t q = (static_cast<std::size_t>(height) - 1 - y) * static_cast<std::size_t>(width) + x;
        const Rgb& c = frame.image.pixels()[p];
        const bool surface = by_depth && std::isfinite(frame.depth[p]);
        color[q * 4] = c.r, color[q * 4 + 1] = c.g, color[q * 4 + 2] = c.b;
        color[q * 4 + 3] = by_depth ? (surface ? 1.0f : 0.0f) : frame.alpha[p];
        if (by_depth) depth[q] = surface ? frame.depth[p] * depth_scale : 1.0f;
      }
  });
  // an empty rectangle: no valid pixel (a null viewport would mean every pixel valid)
  const IceTInt valid[] = {active[0], height - active[3], std::max(0, active[2] - active[0]), std::max(0, active[3] - active[1])};
  const IceTFloat black[] = {0, 0, 0, 0};
  const IceTImage composited = icetCompositeImage(color.data(), by_depth ? depth.data() : nullptr, valid, nullptr, nullptr, black);
  if (const IceTEnum error = icetGetError(); error != ICET_NO_ERROR)
    throw Error(std::string("IceT failed to composite the frame: ") + icet_error_name(error));

  Result out;
  IceTDouble seconds = 0, bytes = 0;
  icetGetDoublev(ICET_COMPOSITE_TIME, &seconds);
  icetGetDoublev(ICET_BYTES_SENT, &bytes);
  out.composite_ms = seconds * 1000.0, out.bytes_sent = bytes;
  IceTInt rank = 0;
  icetGetIntegerv(ICET_RANK, &rank);
  if (rank != 0) return out;
  const IceTFloat* result = icetImageGetColorcf(composited);
  out.image = Image(width, height);
  parallel_for(static_cast<std::size_t>(height), [&](std::size_t y0, std::size_t y1) {
    for (std::size_t y = y0; y < y1; ++y)
      for (std::size_t x = 0; x < static_cast<std::size_t>(width); ++x) {
        const std::size_t q = ((static_cast<std::size_t>(height) - 1 - y) * static_cast<std::size_t>(width) + x) * 4;
        const Rgb c(result[q], result[q + 1], result[q + 2]);
        out.image.pixels()[y * static_cast<std::size_t>(width) + x] =
            by_depth ? (result[q + 3] > 0.5f ? c : background) : c + background * (1 - result[q + 3]);
      }
  });
  return out;
}

#else

bool icet_built() { return false; }

struct IcetCompositor::Context {};

IcetCompositor::IcetCompositor(Compositor) {
  throw Error("this penumbra was built without IceT (run scripts/fetch-icet.sh, then cmake again)");
}

IcetCompositor::~IcetCompositor() = default;

IcetCompositor::Result IcetCompositor::composite(const FrameResult&, const int (&)[4], bool, std::span<const int>, const Rgb&, MpiWorld&) {
  return {};
}

#endif

}  // namespace penumbra
