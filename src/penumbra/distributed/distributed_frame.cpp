#include "penumbra/distributed/distributed_frame.h"

#include <utility>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/distributed/volume_slabs.h"
#include "penumbra/render/renderer.h"

namespace penumbra {
namespace {

// Rows [first(r), first(r + 1)) are band r.
struct Bands {
  int height, count;
  int first(int r) const { return static_cast<int>(static_cast<long long>(height) * r / count); }
  int rows(int r) const { return first(r + 1) - first(r); }
};

// Runs f() on every rank; an exception on any rank becomes the same Error on all of them.
template <class F>
auto on_every_rank(MpiWorld& world, F&& f) -> decltype(f()) {
  std::string error;
  decltype(f()) result{};
  try {
    result = f();
  } catch (const std::exception& e) {
    error = e.what();
    if (error.empty()) error = "unknown error";
  }
  const std::string agreed = world.agree(error);
  if (!agreed.empty()) throw Error(agreed);
  return result;
}

}  // namespace

DistributedFrame render_distributed(const Scene& scene, MpiWorld& world) {
  const int n = world.size(), me = world.rank();
  const SampleSlab slab = on_every_rank(world, [&] {
    check_volumes_only(scene);
    return volume_slabs(*scene.volumes.front().volume, n)[static_cast<std::size_t>(me)];
  });

  // 1. this rank's samples, over black
  // (the shadow maps that combine over bricks are reduced across the ranks inside render())
  std::size_t shadow_bytes = 0;
  const FrameResult frame = on_every_rank(world, [&] {
    Scene over_black = scene;
    over_black.background = Rgb(0.0f);
    Renderer renderer(std::move(over_black));
    FrameRequest request;
    request.slab = slab;
    request.reduction = &world;
    const std::size_t before = world.bytes_sent();
    FrameResult f = renderer.render(request);
    shadow_bytes = world.bytes_sent() - before;
    return f;
  });
  const std::size_t bytes_before_image = world.bytes_sent();

  // 2. direct send: band r of every rank's RGBA to rank r
  const int width = scene.camera.width;
  const Bands bands{scene.camera.height, n};
  const auto floats = [&](int r, int channels) { return bands.rows(r) * width * channels; };
  std::vector<float> send(static_cast<std::size_t>(width) * static_cast<std::size_t>(scene.camera.height) * 4);
  parallel_for(static_cast<std::size_t>(scene.camera.height), [&](std::size_t y0, std::size_t y1) {
    for (std::size_t p = y0 * static_cast<std::size_t>(width); p < y1 * static_cast<std::size_t>(width); ++p) {
      const Rgb& c = frame.image.pixels()[p];
      float* out = &send[p * 4];
      out[0] = c.r, out[1] = c.g, out[2] = c.b, out[3] = frame.alpha[p];
    }
  });
  std::vector<int> send_counts(static_cast<std::size_t>(n)), recv_counts(static_cast<std::size_t>(n), floats(me, 4));
  for (int r = 0; r < n; ++r) send_counts[static_cast<std::size_t>(r)] = floats(r, 4);
  std::vector<float> layers(static_cast<std::size_t>(floats(me, 4)) * static_cast<std::size_t>(n));
  world.all_to_all(send, send_counts, layers, recv_counts);

  // 3. this rank's band, composited along each pixel's ray
  Timer composite;
  const PrimaryRays rays(scene.camera);
  const int y_first = bands.first(me), rows = bands.rows(me);
  const std::size_t layer_floats = static_cast<std::size_t>(floats(me, 4));
  std::vector<float> band(static_cast<std::size_t>(floats(me, 3)));
  parallel_for(static_cast<std::size_t>(rows), [&](std::size_t r0, std::size_t r1) {
    for (int row = static_cast<int>(r0); row < static_cast<int>(r1); ++row)
      for (int x = 0; x < width; ++x) {
        const std::size_t local = static_cast<std::size_t>(row) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x);
        const Rgb c = composite_pixel(static_cast<std::size_t>(n), rays.direction(x, y_first + row).z < 0, scene.background,
                                      [&](std::size_t b) {
                                        const float* l = &layers[b * layer_floats + local * 4];
                                        return std::pair<Rgb, float>(Rgb(l[0], l[1], l[2]), l[3]);
                                      });
        band[local * 3] = c.r, band[local * 3 + 1] = c.g, band[local * 3 + 2] = c.b;
      }
  });
  const double composite_ms = composite.elapsed_ms();

  // 4. the bands to rank 0
  DistributedFrame out;
  std::vector<int> band_counts(static_cast<std::size_t>(n));
  for (int r = 0; r < n; ++r) band_counts[static_cast<std::size_t>(r)] = floats(r, 3);
  std::vector<float> image(me == 0 ? static_cast<std::size_t>(width) * static_cast<std::size_t>(scene.camera.height) * 3 : 0);
  world.gather(band, image, band_counts);
  if (me == 0) {
    out.image = Image(width, scene.camera.height);
    for (std::size_t p = 0; p < out.image.pixels().size(); ++p) out.image.pixels()[p] = Rgb(image[p * 3], image[p * 3 + 1], image[p * 3 + 2]);
  }

  // every rank's figures to rank 0 (this gather's own bytes and time are not in them)
  const double mine[] = {static_cast<double>(slab.z_lo), static_cast<double>(slab.z_hi), frame.prepare_ms, frame.build_ms,
                         frame.render_ms, composite_ms, world.communication_ms(), static_cast<double>(world.bytes_sent()),
                         static_cast<double>(shadow_bytes), static_cast<double>(world.bytes_sent() - bytes_before_image)};
  const std::vector<double> all = world.gather_doubles(mine);
  constexpr std::size_t kFields = std::size(mine);
  for (std::size_t r = 0; r < all.size() / kFields; ++r) {
    const double* f = &all[r * kFields];
    RankFrameStats s;
    s.slab = {static_cast<float>(f[0]), static_cast<float>(f[1])};
    s.prepare_ms = f[2], s.build_ms = f[3], s.render_ms = f[4], s.composite_ms = f[5], s.communication_ms = f[6], s.bytes_sent = f[7];
    s.shadow_bytes_sent = f[8], s.image_bytes_sent = f[9];
    out.ranks.push_back(s);
  }
  return out;
}

}  // namespace penumbra
