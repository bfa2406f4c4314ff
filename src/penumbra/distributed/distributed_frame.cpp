#include "penumbra/distributed/distributed_frame.h"

#include <algorithm>
#include <optional>
#include <utility>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/distributed/sphere_split.h"
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

// A half-open pixel rectangle [x0, x1) × [y0, y1); empty when x0 ≥ x1 or y0 ≥ y1.
struct Rect {
  int x0 = 0, y0 = 0, x1 = 0, y1 = 0;
  bool contains(int x, int y) const { return x >= x0 && x < x1 && y >= y0 && y < y1; }
  std::size_t area() const { return x1 > x0 && y1 > y0 ? static_cast<std::size_t>(x1 - x0) * static_cast<std::size_t>(y1 - y0) : 0; }
  Rect within_rows(int first, int last) const {
    Rect r{x0, std::max(y0, first), x1, std::min(y1, last)};
    return r.area() > 0 ? r : Rect{};
  }
};

// The smallest rectangle holding every pixel the rank's samples touched (opacity or colour not zero);
// outside it the rank's layer is transparent black, so it sends only this (IceT's bounding boxes).
Rect active_rect(const FrameResult& frame) {
  const int width = frame.image.width(), height = frame.image.height();
  std::vector<int> row_x0(static_cast<std::size_t>(height), width), row_x1(static_cast<std::size_t>(height), 0);
  parallel_for(static_cast<std::size_t>(height), [&](std::size_t y0, std::size_t y1) {
    for (std::size_t y = y0; y < y1; ++y)
      for (int x = 0; x < width; ++x) {
        const std::size_t p = y * static_cast<std::size_t>(width) + static_cast<std::size_t>(x);
        const Rgb& c = frame.image.pixels()[p];
        if (frame.alpha[p] != 0 || c.r != 0 || c.g != 0 || c.b != 0) {
          row_x0[y] = std::min(row_x0[y], x);
          row_x1[y] = x + 1;
        }
      }
  });
  Rect r{width, height, 0, 0};
  for (int y = 0; y < height; ++y)
    if (row_x1[static_cast<std::size_t>(y)] > 0) {
      r.x0 = std::min(r.x0, row_x0[static_cast<std::size_t>(y)]);
      r.x1 = std::max(r.x1, row_x1[static_cast<std::size_t>(y)]);
      r.y0 = std::min(r.y0, y);
      r.y1 = y + 1;
    }
  return r.area() > 0 ? r : Rect{};
}

}  // namespace

DistributedRenderer::DistributedRenderer(const Scene& scene, MpiWorld& world, Compositor compositor)
    : world_(world), background_(scene.background), communication_mark_(world.communication_ms()), bytes_mark_(world.bytes_sent()) {
  const int n = world.size(), me = world.rank();
  // a volume's slabs, or (no volume) the spheres split by space and the frames composited by depth
  by_depth_ = splits_spheres(scene);
  std::optional<SphereShare> share;
  world.run_agreed([&] {
    check_splittable(scene);
    if (by_depth_) {
      check_spheres_split(scene, n);
      share = sphere_share(scene, n, me);
      slab_ = share->slab;
    } else {
      slabs_ = volume_slabs(*scene.volumes.front().volume, n);
      slab_ = slabs_[static_cast<std::size_t>(me)];
      // the spheres that reach into the slab, when their structures combine over the ranks
      if (scene.has_particles() && why_spheres_whole(scene).empty()) share = spheres_in_slab(scene, slab_);
    }
    Scene over_black = share ? std::move(share->scene) : scene;
    over_black.background = Rgb(0.0f);
    renderer_ = std::make_unique<Renderer>(std::move(over_black));
    if (compositor != Compositor::direct_send) icet_ = std::make_unique<IcetCompositor>(compositor);
  });
  if (share) spheres_ = share->spheres;
}

DistributedRenderer::~DistributedRenderer() = default;

DistributedFrame DistributedRenderer::render(const Camera& camera, const std::vector<Light>& lights) {
  MpiWorld& world = world_;
  const int n = world.size(), me = world.rank();
  const bool by_depth = by_depth_;
  const SampleSlab slab = slab_;

  // 1. this rank's samples, over black
  // (the light structures that combine over bricks are reduced across the ranks inside render(); a
  // rank that fails there may leave the others inside one of those collectives, so it stops them all)
  std::size_t shadow_bytes = 0;
  const FrameResult frame = [&] {
    try {
      FrameRequest request;
      if (!by_depth) request.slab = slab;
      request.own_spheres = spheres_.has_value();
      request.reduction = &world;
      const std::size_t before = world.bytes_sent();
      FrameResult f = renderer_->render(camera, lights, request);
      shadow_bytes = world.bytes_sent() - before;
      return f;
    } catch (const std::exception& e) {
      if (n == 1) throw;
      world.abort(e.what());
    }
  }();
  const std::size_t bytes_before_image = world.bytes_sent();

  // 2.–4. the layers composited into rank 0's image, by direct send or by IceT
  const Rect rect = active_rect(frame);
  const int active[] = {rect.x0, rect.y0, rect.x1, rect.y1};
  DistributedFrame out;
  double composite_ms = 0, icet_bytes = 0;
  Timer compositing;
  if (icet_) {
    try {
      IcetCompositor::Result composited = icet_->composite(frame, active, by_depth, visibility_order(camera), background_, world);
      out.image = std::move(composited.image);
      composite_ms = composited.composite_ms, icet_bytes = composited.bytes_sent;
    } catch (const std::exception& e) {
      if (n == 1) throw;
      world.abort(e.what());
    }
  } else {
    Composited composited = composite_by_direct_send(frame, camera, active);
    out.image = std::move(composited.image);
    composite_ms = composited.composite_ms;
  }
  const double compositing_ms = compositing.elapsed_ms();

  // every rank's figures to rank 0 (this gather's own bytes and time are not in them)
  const double mine[] = {static_cast<double>(slab.z_lo), static_cast<double>(slab.z_hi), frame.prepare_ms, frame.build_ms,
                         frame.render_ms, composite_ms, world.communication_ms() - communication_mark_,
                         static_cast<double>(world.bytes_sent() - bytes_mark_) + icet_bytes,
                         static_cast<double>(shadow_bytes), static_cast<double>(world.bytes_sent() - bytes_before_image) + icet_bytes,
                         spheres_ ? static_cast<double>(*spheres_) : -1.0, static_cast<double>(frame.rebuilt.size()), compositing_ms};
  const std::vector<double> all = world.gather_doubles(mine);
  communication_mark_ = world.communication_ms(), bytes_mark_ = world.bytes_sent();
  constexpr std::size_t kFields = std::size(mine);
  for (std::size_t r = 0; r < all.size() / kFields; ++r) {
    const double* f = &all[r * kFields];
    RankFrameStats s;
    s.slab = {static_cast<float>(f[0]), static_cast<float>(f[1])};
    s.prepare_ms = f[2], s.build_ms = f[3], s.render_ms = f[4], s.composite_ms = f[5], s.communication_ms = f[6], s.bytes_sent = f[7];
    s.shadow_bytes_sent = f[8], s.image_bytes_sent = f[9];
    if (f[10] >= 0) s.spheres = static_cast<std::size_t>(f[10]);
    s.structures_rebuilt = static_cast<std::size_t>(f[11]);
    s.compositing_ms = f[12];
    out.ranks.push_back(s);
  }
  if (me == 0) out.rebuilt = frame.rebuilt;
  return out;
}

DistributedRenderer::Composited DistributedRenderer::composite_by_direct_send(const FrameResult& frame, const Camera& camera,
                                                                              const int (&active)[4]) {
  MpiWorld& world = world_;
  const int n = world.size(), me = world.rank();
  const bool by_depth = by_depth_;
  // 2. direct send: the part of band r inside this rank's active rectangle, as RGBA (by depth: RGB and
  // the depth), to rank r
  const int width = camera.width, height = camera.height;
  const Bands bands{height, n};
  const Rect mine{active[0], active[1], active[2], active[3]};
  const std::vector<int> all_rects = world.all_gather(active);
  const auto rect_of = [&](int r) {
    const int* v = &all_rects[static_cast<std::size_t>(r) * 4];
    return Rect{v[0], v[1], v[2], v[3]};
  };
  std::vector<int> send_counts(static_cast<std::size_t>(n)), recv_counts(static_cast<std::size_t>(n));
  std::vector<Rect> sent(static_cast<std::size_t>(n)), received(static_cast<std::size_t>(n));
  for (int r = 0; r < n; ++r) {
    sent[static_cast<std::size_t>(r)] = mine.within_rows(bands.first(r), bands.first(r + 1));
    received[static_cast<std::size_t>(r)] = rect_of(r).within_rows(bands.first(me), bands.first(me + 1));
    send_counts[static_cast<std::size_t>(r)] = static_cast<int>(sent[static_cast<std::size_t>(r)].area() * 4);
    recv_counts[static_cast<std::size_t>(r)] = static_cast<int>(received[static_cast<std::size_t>(r)].area() * 4);
  }
  std::vector<float> send;
  for (const Rect& part : sent)
    for (int y = part.y0; y < part.y1; ++y)
      for (int x = part.x0; x < part.x1; ++x) {
        const std::size_t p = static_cast<std::size_t>(y) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x);
        const Rgb& c = frame.image.pixels()[p];
        send.insert(send.end(), {c.r, c.g, c.b, by_depth ? frame.depth[p] : frame.alpha[p]});
      }
  std::vector<std::size_t> layer_start(static_cast<std::size_t>(n) + 1, 0);
  for (int r = 0; r < n; ++r)
    layer_start[static_cast<std::size_t>(r) + 1] = layer_start[static_cast<std::size_t>(r)] + static_cast<std::size_t>(recv_counts[static_cast<std::size_t>(r)]);
  std::vector<float> layers(layer_start.back());
  world.all_to_all(send, send_counts, layers, recv_counts);

  // 3. this rank's band, composited along each pixel's ray (outside a rank's rectangle its layer is
  // transparent black, which leaves the sum as it is), or by depth: the nearest rank's surface, the
  // lowest rank on a tie, else the background (outside a rank's rectangle it shows nothing)
  Composited out;
  Timer composite;
  const PrimaryRays rays(camera);
  const int y_first = bands.first(me), rows = bands.rows(me);
  std::vector<float> band(static_cast<std::size_t>(rows) * static_cast<std::size_t>(width) * 3);
  parallel_for(static_cast<std::size_t>(rows), [&](std::size_t r0, std::size_t r1) {
    for (int row = static_cast<int>(r0); row < static_cast<int>(r1); ++row)
      for (int x = 0; x < width; ++x) {
        const int y = y_first + row;
        const auto layer = [&](std::size_t b) -> const float* {
          const Rect& part = received[b];
          if (!part.contains(x, y)) return nullptr;
          return &layers[layer_start[b] + (static_cast<std::size_t>(y - part.y0) * static_cast<std::size_t>(part.x1 - part.x0) +
                                           static_cast<std::size_t>(x - part.x0)) * 4];
        };
        Rgb c = background_;
        if (by_depth) {
          float nearest = kInfinity;
          for (std::size_t b = 0; b < static_cast<std::size_t>(n); ++b)
            if (const float* l = layer(b); l && l[3] < nearest) nearest = l[3], c = Rgb(l[0], l[1], l[2]);
        } else {
          c = composite_pixel(static_cast<std::size_t>(n), rays.direction(x, y).z < 0, background_, [&](std::size_t b) {
            const float* l = layer(b);
            return l ? std::pair<Rgb, float>(Rgb(l[0], l[1], l[2]), l[3]) : std::pair<Rgb, float>(Rgb(0.0f), 0.0f);
          });
        }
        const std::size_t local = static_cast<std::size_t>(row) * static_cast<std::size_t>(width) + static_cast<std::size_t>(x);
        band[local * 3] = c.r, band[local * 3 + 1] = c.g, band[local * 3 + 2] = c.b;
      }
  });
  out.composite_ms = composite.elapsed_ms();

  // 4. the bands to rank 0
  std::vector<int> band_counts(static_cast<std::size_t>(n));
  for (int r = 0; r < n; ++r) band_counts[static_cast<std::size_t>(r)] = bands.rows(r) * width * 3;
  std::vector<float> image(me == 0 ? static_cast<std::size_t>(width) * static_cast<std::size_t>(height) * 3 : 0);
  world.gather(band, image, band_counts);
  if (me == 0) {
    out.image = Image(width, height);
    for (std::size_t p = 0; p < out.image.pixels().size(); ++p) out.image.pixels()[p] = Rgb(image[p * 3], image[p * 3 + 1], image[p * 3 + 2]);
  }
  return out;
}

std::vector<int> DistributedRenderer::visibility_order(const Camera& camera) const {
  const int n = world_.size();
  std::vector<int> order;
  if (slabs_.empty()) {  // by depth: any order
    for (int r = 0; r < n; ++r) order.push_back(r);
    return order;
  }
  int eye = 0;  // the slab holding the eye's z (slabs cover every z)
  while (eye + 1 < n && camera.eye.z >= slabs_[static_cast<std::size_t>(eye)].z_hi) ++eye;
  order.push_back(eye);
  for (int d = 1; d < n; ++d) {
    if (eye + d < n) order.push_back(eye + d);
    if (eye - d >= 0) order.push_back(eye - d);
  }
  return order;
}

DistributedFrame render_distributed(const Scene& scene, MpiWorld& world, Compositor compositor) {
  return DistributedRenderer(scene, world, compositor).render(scene.camera, scene.lights);
}

}  // namespace penumbra
