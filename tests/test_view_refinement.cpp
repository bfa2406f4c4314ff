// View-dependent refinement (render/view_refinement.h): the seen part of a box against brute force, the
// level a view asks for, a box of a pyramid's level against the whole level, and full frames of a
// pyramid opened coarse against the finest level held in memory, with what they load, keep and evict.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <thread>

#include "ball_volumes.h"
#include "image_check.h"
#include "penumbra/core/cancel.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/io/zarr_writer.h"
#include "penumbra/data/procedural.h"
#include "penumbra/render/renderer.h"
#include "penumbra/render/view_refinement.h"
#include "penumbra/scene_io/scene_file.h"
#include "test_scenes.h"
#include "test_volume_io_util.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

// Whether p projects into the camera's image, in front of the eye.
bool seen_by(const Camera& camera, const Vec3& p) {
  const PrimaryRays rays(camera);
  const Vec3 d = p - camera.eye;
  const float z = -dot(d, rays.frame.w);
  if (z <= 0) return false;
  const float px = rays.pixel_x(dot(d, rays.frame.u) / z), py = rays.pixel_y(dot(d, rays.frame.v) / z);
  return px >= 0 && px <= static_cast<float>(camera.width) && py >= 0 && py <= static_cast<float>(camera.height);
}

// The bounds of a dense lattice of the box's points that the camera sees.
Box3 lattice_seen(const Camera& camera, const Box3& box, int n) {
  Box3 seen;
  for (int k = 0; k <= n; ++k)
    for (int j = 0; j <= n; ++j)
      for (int i = 0; i <= n; ++i) {
        const Vec3 f{static_cast<float>(i) / static_cast<float>(n), static_cast<float>(j) / static_cast<float>(n), static_cast<float>(k) / static_cast<float>(n)};
        const Vec3 p = box.lo + box.extent() * f;
        if (seen_by(camera, p)) seen.extend(p);
      }
  return seen;
}

// The bounds of where a dense grid of the camera's rays (the image's borders included) enter and leave
// the box: frustum ∩ box is the union of those segments, and a coordinate is extreme at an end of one.
Box3 ray_segments_seen(const Camera& camera, const Box3& box, int n) {
  const PrimaryRays rays(camera);
  Box3 seen;
  if (box.contains(camera.eye)) seen.extend(camera.eye);
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const Vec3 d = rays.direction(static_cast<float>(camera.width) * static_cast<float>(i) / static_cast<float>(n),
                                    static_cast<float>(camera.height) * static_cast<float>(j) / static_cast<float>(n));
      float t0 = 0, t1 = 0;
      if (!box.clip(Ray{camera.eye, d}, t0, t1)) continue;
      seen.extend(camera.eye + d * t0);
      seen.extend(camera.eye + d * t1);
    }
  return seen;
}

// The camera moved sideways by `shift`, looking the same way.
Camera panned(const Camera& camera, const Vec3& shift) {
  Camera c = camera;
  c.eye = c.eye + shift;
  c.target = c.target + shift;
  return c;
}

// A pan past the box's margin: a new box read without error, taking voxels the box held before.
void expect_box_reused(const RefinementStats& r) {
  EXPECT_TRUE(r.error.empty()) << r.error;
  EXPECT_GT(r.loaded_bytes, 0u) << "the pan must leave the box";
  EXPECT_GT(r.reused_bytes, 0u);
}

}  // namespace

// The seen part is exact: it holds every point of the box the camera sees, and no lattice point of a
// fine sampling lies farther than a lattice step inside it (so it is no looser than the sampling).
TEST(ViewRefinement, SeenPartIsTheBoundsOfFrustumAndBox) {
  const Box3 box{{-1.0f, -0.5f, -2.0f}, {1.5f, 0.5f, 2.0f}};
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1, 1);
  int partial = 0, none = 0, inside = 0;
  for (int trial = 0; trial < 60; ++trial) {
    Camera c;
    c.width = 64 + trial % 3 * 32;  // wide and tall images too
    c.height = 64 + trial % 2 * 48;
    c.fov_deg = 20.0f + static_cast<float>(trial % 5) * 12.0f;
    const float reach = trial % 4 == 0 ? 0.8f : 6.0f;  // a quarter of the cameras in or near the box
    c.eye = Vec3{u(rng), u(rng), u(rng)} * reach;
    c.target = Vec3{u(rng), u(rng), u(rng)} * 1.5f;
    if (length(c.target - c.eye) < 0.2f) continue;
    const Box3 part = visible_part(c, box);
    const Box3 lattice = lattice_seen(c, box, 40), segments = ray_segments_seen(c, box, 400);
    if (box.contains(c.eye)) ++inside;
    if (segments.empty()) {
      ++none;
      EXPECT_TRUE(lattice.empty());
      continue;
    }
    ASSERT_FALSE(part.empty()) << "trial " << trial;
    const float slack = 0.01f * box.radius();
    for (int a = 0; a < 3; ++a) {
      if (!lattice.empty()) {  // every point seen lies in it
        EXPECT_LE(part.lo[a], lattice.lo[a] + 1e-4f) << "trial " << trial << " axis " << a;
        EXPECT_GE(part.hi[a], lattice.hi[a] - 1e-4f) << "trial " << trial << " axis " << a;
      }
      EXPECT_NEAR(part.lo[a], segments.lo[a], slack) << "trial " << trial << " axis " << a;  // and it is tight
      EXPECT_NEAR(part.hi[a], segments.hi[a], slack) << "trial " << trial << " axis " << a;
    }
    if (part.extent().x < box.extent().x * 0.99f || part.extent().z < box.extent().z * 0.99f) ++partial;
  }
  EXPECT_GT(partial, 10);  // the cases that matter: a part of the box, not all of it
  EXPECT_GT(inside, 2);
  // a camera looking away sees nothing
  Camera away;
  away.eye = {0, 0, 5};
  away.target = {0, 0, 10};
  EXPECT_TRUE(visible_part(away, box).empty());
}

// The level a view asks for: none while the opened level's voxel is no larger than a pixel, the finest
// that fits the bytes, never finer than a pixel needs; the box covers the seen part with the apron.
TEST(ViewRefinement, ChoosesTheCoarsestLevelAsFineAsAPixelThatFits) {
  PyramidSource p;
  p.type = ScalarType::UInt16;
  for (int l = 0; l < 4; ++l) {
    const int n = 256 >> l;
    const float s = static_cast<float>(1 << l) / 256.0f;
    p.levels.push_back({{n, n, n}, {s, s, s}, Vec3{-0.5f, -0.5f, -0.5f} + Vec3{s, s, s} * 0.5f});
  }
  p.opened = 3;  // 32³
  const Box3 box{{-0.5f, -0.5f, -0.5f}, {0.5f, 0.5f, 0.5f}};
  Camera c;
  c.width = c.height = 512;
  c.fov_deg = 30;
  c.target = {0.3f, 0.3f, 0.3f};
  auto choose = [&](float distance, std::uint64_t bytes, bool cut = false) {
    c.eye = c.target + normalize(Vec3{1, 0.7f, 0.4f}) * distance;
    return choose_refinement(c, p, box, bytes, true, cut);
  };
  // far away: a 32³ voxel (1/32) is smaller than a pixel there
  EXPECT_FALSE(choose(60.0f, ~std::uint64_t{0}).has_value());
  // near, all the memory wanted: the level whose voxel first fits in a pixel; pixel = d · 2 tan 15° / 512
  for (const float d : {0.5f, 1.0f, 2.0f}) {
    const auto choice = choose(d, ~std::uint64_t{0});
    ASSERT_TRUE(choice.has_value());
    const Box3 seen = choice->seen;
    for (int a = 0; a < 3; ++a) {  // all of it: the opened level's voxel is larger than a pixel up to depth 30
      EXPECT_FLOAT_EQ(seen.lo[a], visible_part(c, box).lo[a]);
      EXPECT_FLOAT_EQ(seen.hi[a], visible_part(c, box).hi[a]);
    }
    const float pixel = dot(seen.center() - c.eye, normalize(c.target - c.eye)) * 2.0f * std::tan(radians(15.0f)) / 512.0f;
    const float voxel = p.levels[static_cast<std::size_t>(choice->box.level)].spacing.x;
    EXPECT_TRUE(voxel <= pixel || choice->box.level == 0) << d;
    if (choice->box.level + 1 < p.opened) {
      EXPECT_GT(voxel * 2, pixel) << d;  // the next coarser was not enough
    }
    EXPECT_TRUE(choice->stored_gradients);
    // the box covers the seen part
    const PyramidSource::Level& l = p.levels[static_cast<std::size_t>(choice->box.level)];
    for (int a = 0; a < 3; ++a) {
      EXPECT_LE(l.origin[a] + static_cast<float>(choice->box.lo[static_cast<std::size_t>(a)]) * l.spacing[a], std::max(seen.lo[a], l.origin[a]));
      EXPECT_GE(l.origin[a] + static_cast<float>(choice->box.hi[static_cast<std::size_t>(a)] - 1) * l.spacing[a],
                std::min(seen.hi[a], l.origin[a] + static_cast<float>(l.dims[static_cast<std::size_t>(a)] - 1) * l.spacing[a]));
    }
  }
  // close up, bytes for level 1's box but not level 0's: level 1; bytes for nothing finer: none
  const auto finest = choose(0.5f, ~std::uint64_t{0});
  ASSERT_TRUE(finest && finest->box.level == 0);
  const LevelBox level1 = level_box(p, 1, visible_part(c, box));
  const std::uint64_t bytes = refined_bytes(level1, p.type, false) + 16;
  const auto fitted = choose(0.5f, bytes);
  ASSERT_TRUE(fitted.has_value());
  EXPECT_EQ(fitted->box.level, 1);
  EXPECT_LE(refined_bytes(fitted->box, p.type, fitted->stored_gradients), bytes);
  EXPECT_FALSE(fitted->stored_gradients);
  const LevelBox level2 = level_box(p, 2, visible_part(c, box));
  EXPECT_FALSE(choose(0.5f, refined_bytes(level2, p.type, false) - 1).has_value());
  // a third of what level 0's box of the whole view needs: without cutting, a coarser level; cutting,
  // level 0 for the near part of the view
  const LevelBox level0 = level_box(p, 0, visible_part(c, box));
  const std::uint64_t third = refined_bytes(level0, p.type, false) / 3;
  const auto uncut = choose(0.5f, third, false), cut = choose(0.5f, third, true);
  ASSERT_TRUE(uncut && cut);
  EXPECT_GT(uncut->box.level, 0);
  EXPECT_EQ(cut->box.level, 0);
  EXPECT_LE(refined_bytes(cut->box, p.type, cut->stored_gradients), third);
  const Vec3 ahead = normalize(c.target - c.eye);
  auto depths = [&](const Box3& b) {
    float lo = kInfinity, hi = -kInfinity;
    for (int k = 0; k < 8; ++k) {
      lo = std::min(lo, dot(b.corner(k) - c.eye, ahead));
      hi = std::max(hi, dot(b.corner(k) - c.eye, ahead));
    }
    return std::make_pair(lo, hi);
  };
  const auto [whole_near, whole_far] = depths(visible_part(c, box));
  const auto [cut_near, cut_far] = depths(cut->seen);
  EXPECT_NEAR(cut_near, whole_near, 1e-4f);  // from the front of the view
  EXPECT_LT(cut_far, whole_far - 0.1f);      // to a depth before its back
  EXPECT_GT(cut_far, whole_near + 0.25f * (whole_far - whole_near) - 1e-3f);
}

// A box of a level (load_zarr_box) is that level's voxels, placed where they lie, its chunks only read.
TEST(ViewRefinement, ABoxOfALevelIsThatLevelsVoxels) {
  ScratchDir dir;
  write_numbered_pyramid(dir.file("v.zarr"), {37, 30, 26});
  const std::vector<LevelGrid> grids = zarr_level_grids(dir.file("v.zarr"));
  ASSERT_GE(grids.size(), 2u);
  for (const int level : {0, 1}) {
    VolumeLoadOptions lo;
    lo.level = level;
    const Volume whole = load_volume(dir.file("v.zarr"), lo);
    EXPECT_EQ(grids[static_cast<std::size_t>(level)].dims, whole.dims());
    for (int a = 0; a < 3; ++a) {
      EXPECT_FLOAT_EQ(grids[static_cast<std::size_t>(level)].spacing[a], whole.spacing()[a]);
      EXPECT_FLOAT_EQ(grids[static_cast<std::size_t>(level)].origin[a], whole.origin()[a]);
    }
    const auto& d = whole.dims();
    for (const auto& [lo3, hi3] : std::vector<std::pair<std::array<std::int64_t, 3>, std::array<std::int64_t, 3>>>{
             {{3, 5, 7}, {13, 11, 9}}, {{0, 0, 0}, {d[0], d[1], d[2]}}, {{d[0] - 2, 1, 0}, {d[0], 9, 4}}}) {
      WindowRead read;
      const Volume box = load_zarr_box(dir.file("v.zarr"), level, -1, lo3, hi3, &read);
      ASSERT_EQ(box.dims(), (std::array<int, 3>{static_cast<int>(hi3[0] - lo3[0]), static_cast<int>(hi3[1] - lo3[1]), static_cast<int>(hi3[2] - lo3[2])}));
      EXPECT_FALSE(box.is_window());
      for (int a = 0; a < 3; ++a)
        EXPECT_NEAR(box.origin()[a], whole.origin()[a] + static_cast<float>(lo3[static_cast<std::size_t>(a)]) * whole.spacing()[a], 1e-4f);
      EXPECT_EQ(box.opacity_length(), whole.opacity_length());
      for (int k = 0; k < box.dims()[2]; ++k)
        for (int j = 0; j < box.dims()[1]; ++j)
          for (int i = 0; i < box.dims()[0]; ++i)
            ASSERT_EQ(box.value(i, j, k), whole.value(i + static_cast<int>(lo3[0]), j + static_cast<int>(lo3[1]), k + static_cast<int>(lo3[2])));
      EXPECT_GT(read.bytes_read, 0u);
    }
  }
  // a box read beside one held before takes the chunks inside that one from it: the same voxels, fewer read
  for (const auto& [held_lo, held_hi] : std::vector<std::pair<std::array<std::int64_t, 3>, std::array<std::int64_t, 3>>>{
           {{0, 0, 0}, {24, 22, 17}}, {{5, 3, 2}, {37, 30, 26}}, {{8, 8, 8}, {16, 16, 16}}, {{30, 0, 0}, {37, 6, 5}}}) {
    const Volume before = load_zarr_box(dir.file("v.zarr"), 0, -1, held_lo, held_hi);
    const HeldBox held{held_lo, held_hi, &before};
    const std::array<std::int64_t, 3> lo3{6, 4, 3}, hi3{33, 27, 24};
    WindowRead fresh_read, lent_read;
    const Volume fresh = load_zarr_box(dir.file("v.zarr"), 0, -1, lo3, hi3, &fresh_read);
    const Volume lent = load_zarr_box(dir.file("v.zarr"), 0, -1, lo3, hi3, &lent_read, &held);
    ASSERT_EQ(lent.dims(), fresh.dims());
    for (std::size_t n = 0; n < fresh.voxel_count(); ++n) ASSERT_EQ(lent.value(n), fresh.value(n)) << "voxel " << n;
    EXPECT_EQ(lent.min_value(), fresh.min_value());
    EXPECT_EQ(lent.max_value(), fresh.max_value());
    EXPECT_EQ(fresh_read.bytes_reused, 0u);
    if (held_lo[0] == 30) {  // it holds no whole chunk part of the new box: all read
      EXPECT_EQ(lent_read.bytes_reused, 0u);
      EXPECT_EQ(lent_read.bytes_read, fresh_read.bytes_read);
    } else {
      EXPECT_GT(lent_read.bytes_reused, 0u);
      EXPECT_LT(lent_read.bytes_read, fresh_read.bytes_read);
    }
  }
  // a box held that gives its voxels up to a new box of its size moves them in place: the same voxels as
  // a fresh read, the chunks inside it not read, and no second box allocated
  // (or no larger: a box of other dimensions in the same memory)
  for (const auto& [by, grow] : std::vector<std::pair<std::array<std::int64_t, 3>, std::array<std::int64_t, 3>>>{
           {{3, 0, 0}, {0, 0, 0}}, {{-2, 4, 1}, {0, 0, 0}}, {{0, 0, -5}, {0, 0, 0}}, {{-8, -6, -7}, {0, 0, 0}}, {{4, -3, 2}, {8, -4, -1}},
           {{-5, 2, 0}, {-5, 4, 0}}}) {
    const std::array<std::int64_t, 3> held_lo{8, 6, 7}, held_hi{25, 20, 19};
    const std::array<std::int64_t, 3> lo3{held_lo[0] + by[0], held_lo[1] + by[1], held_lo[2] + by[2]};
    const std::array<std::int64_t, 3> hi3{held_hi[0] + by[0] + grow[0], held_hi[1] + by[1] + grow[1], held_hi[2] + by[2] + grow[2]};
    Volume storage = load_zarr_box(dir.file("v.zarr"), 0, -1, held_lo, held_hi);
    const std::byte* memory = storage.data();
    HeldBox held{held_lo, held_hi, &storage, &storage};
    WindowRead fresh_read, moved_read;
    const Volume fresh = load_zarr_box(dir.file("v.zarr"), 0, -1, lo3, hi3, &fresh_read);
    const Volume moved = load_zarr_box(dir.file("v.zarr"), 0, -1, lo3, hi3, &moved_read, &held);
    EXPECT_EQ(storage.voxel_count(), 0u) << "the held box's own voxels, taken";
    if (grow == std::array<std::int64_t, 3>{0, 0, 0}) {  // (a resize may move them: AddressSanitizer's realloc always does)
      EXPECT_EQ(moved.data(), memory);
    }
    ASSERT_EQ(moved.dims(), fresh.dims());
    for (std::size_t n = 0; n < fresh.voxel_count(); ++n) ASSERT_EQ(moved.value(n), fresh.value(n)) << "voxel " << n;
    for (int a = 0; a < 3; ++a) EXPECT_EQ(moved.origin()[a], fresh.origin()[a]);
    EXPECT_EQ(moved.min_value(), fresh.min_value());
    EXPECT_EQ(moved.max_value(), fresh.max_value());
    EXPECT_EQ(moved.opacity_length(), fresh.opacity_length());
    EXPECT_GT(moved_read.bytes_reused, 0u);
    EXPECT_LT(moved_read.bytes_read, fresh_read.bytes_read);
  }
  {  // a held box with fewer voxels grows into the new box: its storage taken, the same voxels, fewer read
    Volume storage = load_zarr_box(dir.file("v.zarr"), 0, -1, {0, 0, 0}, {24, 22, 17});
    HeldBox held{{0, 0, 0}, {24, 22, 17}, &storage, &storage};
    WindowRead fresh_read, grown_read;
    const Volume fresh = load_zarr_box(dir.file("v.zarr"), 0, -1, {6, 4, 3}, {33, 27, 24}, &fresh_read);
    const Volume grown = load_zarr_box(dir.file("v.zarr"), 0, -1, {6, 4, 3}, {33, 27, 24}, &grown_read, &held);
    EXPECT_EQ(storage.voxel_count(), 0u) << "taken";
    ASSERT_EQ(grown.dims(), fresh.dims());
    for (std::size_t n = 0; n < fresh.voxel_count(); ++n) ASSERT_EQ(grown.value(n), fresh.value(n)) << "voxel " << n;
    EXPECT_GT(grown_read.bytes_reused, 0u);
    EXPECT_LT(grown_read.bytes_read, fresh_read.bytes_read);
  }
  EXPECT_THROW(load_zarr_box(dir.file("v.zarr"), 0, -1, {0, 0, 0}, {38, 4, 4}), Error);
  EXPECT_THROW(load_zarr_box(dir.file("v.zarr"), 0, -1, {4, 0, 0}, {4, 4, 4}), Error);
}

namespace {

// The balls (ball_volumes.h) as a pyramid of 8³ chunks.
std::string write_ball_pyramid(const ScratchDir& dir, int size, float small_density = 0.5f, const std::string& name = "ball.zarr") {
  OmeZarrWriteOptions options;
  options.chunk = 8;
  write_ome_zarr(ball_volume(size, small_density), dir.file(name), options);
  return dir.file(name);
}

nlohmann::json ball_scene(const std::string& store, std::uint64_t budget, bool refine) { return ball_view_scene(store, budget, refine, "none"); }

// The balls' pyramid under `budget`, seen narrowly (a box of a fraction of what the budget leaves).
Scene narrow_ball_scene(const std::string& store, std::uint64_t budget, float fov_deg) {
  nlohmann::json j = ball_scene(store, budget, true);
  j["camera"]["fov_deg"] = fov_deg;
  return build_scene(j, "");
}

// A full frame drawn from a refined box against the frame of the finest level in memory: equal within
// `max_abs` and not blank (the images kept under `label` when it fails); the difference is printed.
void expect_refined_equals_memory(const Image& refined, const Image& in_memory, double max_abs, const std::string& label) {
  FailureImages keep;
  keep.add(label, refined, in_memory);
  const ImageDifference error = compare_images(refined, in_memory);
  std::printf("[measure] %s: max %.4f, rmse %.5f against level 0 in memory\n", label.c_str(), error.max_abs, error.rmse);
  EXPECT_LT(error.max_abs, max_abs) << "rmse " << error.rmse;
  EXPECT_TRUE(non_trivial(refined));
}

}  // namespace

// A pyramid opened at a coarse level under a budget draws a close view, in full frames, from the
// finest level: the frame equals the frame of the finest level held whole in memory (the eye pass is
// exact: same samples, same lattice, same table), where the opened level alone is far from it; a
// preview stays on the opened level; the box is kept while the view stays in it and given up when the
// camera backs away, and what it holds stays within what the budget leaves.
TEST(ViewRefinement, AFullFrameOfACloseViewIsTheFinestLevels) {
  ScratchDir dir;
  const std::string store = write_ball_pyramid(dir, 64);
  const std::uint64_t budget = 1u << 20;  // 64³ float32 is 1 MiB: level 1 (32³, 128 KiB) opens
  const Scene coarse_scene = build_scene(ball_scene(store, budget, true), "");
  ASSERT_EQ(coarse_scene.volumes[0].volume->dims()[0], 32);
  ASSERT_TRUE(coarse_scene.volumes[0].pyramid);
  EXPECT_EQ(coarse_scene.volumes[0].pyramid->opened, 1);
  Renderer refined(coarse_scene);
  const FrameResult full = refined.render();
  ASSERT_EQ(full.refinement.size(), 1u);
  const RefinementStats& s = full.refinement.front();
  EXPECT_EQ(s.opened_level, 1);
  EXPECT_EQ(s.level, 0);
  EXPECT_GT(s.loaded_bytes, 0u);
  EXPECT_GT(s.read_bytes, 0u);
  EXPECT_EQ(s.held_bytes, s.loaded_bytes);
  EXPECT_LE(s.held_bytes, coarse_scene.refinement_bytes);
  EXPECT_LT(s.dims[0] * s.dims[1] * s.dims[2], 64 * 64 * 64);  // a part of the level, not all of it
  EXPECT_NE(std::find(full.rebuilt.begin(), full.rebuilt.end(), "volumes.0.refined"), full.rebuilt.end());

  const Image in_memory = Renderer(build_scene(ball_scene(store, 0, true), "")).render().image;
  const Image opened_only = Renderer(build_scene(ball_scene(store, budget, false), "")).render().image;
  FailureImages keep;
  keep.add("refined", full.image, in_memory);
  keep.add("opened", opened_only, in_memory);
  const ImageDifference refined_error = compare_images(full.image, in_memory), opened_error = compare_images(opened_only, in_memory);
  EXPECT_LT(refined_error.max_abs, 1e-4) << "rmse " << refined_error.rmse;
  EXPECT_GT(opened_error.rmse, 0.01);  // what refinement is for
  EXPECT_TRUE(non_trivial(full.image));

  // a preview draws the opened level and loads nothing
  FrameRequest preview;
  preview.quality = Quality::Preview;
  preview.preview_divisor = 1;
  const FrameResult p = refined.render(preview);
  EXPECT_TRUE(p.refinement.empty());
  Renderer unrefined(build_scene(ball_scene(store, budget, false), ""));
  (void)unrefined.render();
  const Image opened_preview = unrefined.render(preview).image;
  keep.add("preview", p.image, opened_preview);
  EXPECT_EQ(compare_images(p.image, opened_preview).max_abs, 0.0);
  // the same view again: the box is kept
  const FrameResult again = refined.render();
  ASSERT_EQ(again.refinement.size(), 1u);
  EXPECT_EQ(again.refinement.front().loaded_bytes, 0u);
  EXPECT_EQ(again.refinement.front().held_bytes, s.held_bytes);
  EXPECT_LT(compare_images(again.image, in_memory).max_abs, 1e-4);
  // a small turn stays inside the box (its margin)
  Camera turned = coarse_scene.camera.orbited(0.02f);
  const FrameResult small_turn = refined.render(turned, coarse_scene.lights);
  ASSERT_EQ(small_turn.refinement.size(), 1u);
  EXPECT_EQ(small_turn.refinement.front().loaded_bytes, 0u);
  // backing away: the opened level is enough; the box is no longer drawn but kept (the budget holds it)
  Camera far = coarse_scene.camera;
  far.eye = far.target + (far.eye - far.target) * 40.0f;
  const FrameResult backed = refined.render(far, coarse_scene.lights);
  ASSERT_EQ(backed.refinement.size(), 1u);
  EXPECT_EQ(backed.refinement.front().evicted_bytes, 0u);
  EXPECT_EQ(backed.refinement.front().held_bytes, 0u);
  EXPECT_EQ(backed.refinement.front().kept_bytes, s.held_bytes);
  EXPECT_EQ(refined.refined_memory_bytes(), s.held_bytes);
  const Image far_expected = unrefined.render(far, coarse_scene.lights).image;
  EXPECT_EQ(compare_images(backed.image, far_expected).max_abs, 0.0);
  // coming back: drawn from the box kept, nothing read
  const FrameResult back = refined.render(coarse_scene.camera, coarse_scene.lights);
  ASSERT_EQ(back.refinement.size(), 1u);
  EXPECT_EQ(back.refinement.front().loaded_bytes, 0u);
  EXPECT_EQ(back.refinement.front().read_bytes, 0u);
  EXPECT_EQ(back.refinement.front().held_bytes, s.held_bytes);
  EXPECT_EQ(back.refinement.front().kept_bytes, 0u);
  EXPECT_NE(std::find(back.rebuilt.begin(), back.rebuilt.end(), "volumes.0.refined"), back.rebuilt.end());
  EXPECT_LT(compare_images(back.image, in_memory).max_abs, 1e-4);
}

// A wide, deep view whose finest box does not fit what the budget leaves: the near part of the view is
// drawn from the finest level, the rest from the opened level on the same lattice; the frame is nearer
// the finest level's in memory than the opened level's frame is, and (the balls translucent) what lies
// behind the box still shows.
TEST(ViewRefinement, TheNearPartOfADeepViewIsRefinedWhereTheWholeDoesNotFit) {
  ScratchDir dir;
  const std::string store = write_ball_pyramid(dir, 64);
  auto deep = [&](std::uint64_t budget, bool refine) {
    nlohmann::json j = ball_scene(store, budget, refine);
    j["volumes"][0]["transfer_function"] = {{"points", {{0.0, 0.2, 0.4, 0.9, 0.0}, {0.4, 0.2, 0.4, 0.9, 0.0}, {0.5, 0.9, 0.5, 0.2, 0.03},
                                                       {1.0, 1.0, 0.9, 0.8, 0.04}}}};
    j["camera"] = {{"eye", {-0.3, 0.1, 0.9}}, {"target", {0.1, 0.0, -0.5}}, {"fov_deg", 40}, {"width", 96}, {"height", 96}};
    return build_scene(j, "");
  };
  // a third of level 0's box of the whole view fits, then a box just past the balls' near side
  for (const std::uint64_t budget : {std::uint64_t{1} << 20, std::uint64_t{450000}}) {
    SCOPED_TRACE("budget " + std::to_string(budget));
    const Scene scene = deep(budget, true);
    Renderer renderer(scene);
    const FrameResult full = renderer.render();
    ASSERT_EQ(full.refinement.size(), 1u);
    const RefinementStats& s = full.refinement.front();
    EXPECT_EQ(s.level, 0);
    EXPECT_LE(s.held_bytes, scene.refinement_bytes);
    EXPECT_LT(s.dims[2], 64);  // the near part only: the box stops before the volume's far side
    const FrameResult in_memory = Renderer(deep(0, true)).render();
    const FrameResult opened = Renderer(deep(budget, false)).render();
    FailureImages keep;
    keep.add("refined", full.image, in_memory.image);
    keep.add("opened", opened.image, in_memory.image);
    const double refined_error = compare_images(full.image, in_memory.image).rmse;
    const double opened_error = compare_images(opened.image, in_memory.image).rmse;
    EXPECT_LT(refined_error, 0.75 * opened_error) << refined_error << " against " << opened_error;
    EXPECT_GT(refined_error, 0.0);  // the far part is the opened level's
    // what lies behind the box shows: its opacity is no farther from the in-memory frame's than the
    // opened level's is (a ray cut short at the box would lose it)
    double refined_alpha = 0, opened_alpha = 0;
    for (std::size_t p = 0; p < full.alpha.size(); ++p) {
      refined_alpha += std::abs(full.alpha[p] - in_memory.alpha[p]);
      opened_alpha += std::abs(opened.alpha[p] - in_memory.alpha[p]);
    }
    EXPECT_LE(refined_alpha, opened_alpha) << "summed opacity differences";
  }
}

namespace {

// A 48³ field of two smooth balls (density 1 at their centres): one at voxel 20 inside the box
// [10, 30)³, one at voxel 38 outside it.
float two_balls(int i, int j, int k, bool inner, bool outer) {
  auto ball = [&](float c, float radius) {
    const float dx = static_cast<float>(i) - c, dy = static_cast<float>(j) - c, dz = static_cast<float>(k) - c;
    return std::clamp(1.0f - (dx * dx + dy * dy + dz * dz) / (radius * radius), 0.0f, 1.0f);
  };
  return (inner ? ball(20, 6) : 0.0f) + (outer ? ball(38, 5) : 0.0f);
}

Volume ball_grid(std::array<int, 3> lo, std::array<int, 3> hi, bool inner, bool outer) {
  const float s = 1.0f / 48.0f;
  Volume v(ScalarType::Float32, {hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]}, {s, s, s},
           {static_cast<float>(lo[0]) * s, static_cast<float>(lo[1]) * s, static_cast<float>(lo[2]) * s});
  std::size_t n = 0;
  for (int k = lo[2]; k < hi[2]; ++k)
    for (int j = lo[1]; j < hi[1]; ++j)
      for (int i = lo[0]; i < hi[0]; ++i) v.set_value(n++, two_balls(i, j, k, inner, outer));
  v.set_value_range(0, 1);  // one table for all three grids
  return v;
}

VolumeObject casting(const Volume& v) {
  VolumeObject o;
  o.volume = std::make_shared<const Volume>(v);
  o.transfer_function = TransferFunction({{0.0f, Rgb(1.0f), 0.0f}, {0.05f, Rgb(1.0f), 0.0f}, {1.0f, Rgb(0.8f, 0.5f, 0.3f), 0.2f}});
  return o;
}

}  // namespace

// The casters' march over a volume with a refined box classifies a segment in the box where its
// midpoint lies there and in the opened level elsewhere, on one lattice: with the box cut from the
// whole grid and the opened grid lacking what the box holds (its macrocells empty there), every light
// ray's transmittance equals the whole grid's — exactly, so no segment is skipped into the box or past
// it, and none is classified in the wrong grid.
TEST(ViewRefinement, CastersReadTheRefinedBoxWhereItLies) {
  const Volume whole = ball_grid({0, 0, 0}, {48, 48, 48}, true, true);
  const Volume opened = ball_grid({0, 0, 0}, {48, 48, 48}, false, true);  // the inner ball only in the box
  const Volume box = ball_grid({10, 10, 10}, {30, 30, 30}, true, true);
  Scene whole_scene, refined_scene;
  whole_scene.volumes = {casting(whole)};
  refined_scene.volumes = {casting(opened)};
  const VolumeObject box_object = casting(box);
  const MacrocellGrid whole_grid(whole), opened_grid(opened), box_grid(box);
  const MacrocellGrid* whole_grids[] = {&whole_grid};
  const MacrocellGrid* opened_grids[] = {&opened_grid};
  const ShadowCasters::FinerBox finer[] = {{&box_object, &box_grid}};
  const ShadowCasters reference(whole_scene, whole_grids), refined(refined_scene, opened_grids, finer),
      unrefined(refined_scene, opened_grids);
  ASSERT_EQ(reference.step(), refined.step());
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  int through_box = 0;
  double unrefined_error = 0;
  for (int n = 0; n < 2000; ++n) {
    // rays from outside the grid through a point near the inner ball, the outer ball or anywhere
    const Vec3 via = n % 3 == 0 ? Vec3{u(rng), u(rng), u(rng)} : Vec3{20.0f / 48, 20.0f / 48, 20.0f / 48} + Vec3{u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f} * 0.3f;
    const Vec3 dir = normalize(Vec3{u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f});
    const Ray ray{via - dir * 2.0f, dir};
    const Rgb expected = reference.transmittance(ray, 0.0f, 4.0f);
    const Rgb got = refined.transmittance(ray, 0.0f, 4.0f);
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(got[c], expected[c], 1e-6f) << "ray " << n << " channel " << c;
    float b0, b1;
    if (box.bounds().clip(ray, b0, b1, 0.0f, 4.0f) && expected.max_component() < 0.99f) ++through_box;
    unrefined_error += std::abs(unrefined.transmittance(ray, 0.0f, 4.0f).g - expected.g);
  }
  EXPECT_GT(through_box, 500);        // many rays were shadowed in the box
  EXPECT_GT(unrefined_error, 50.0);   // without the box the inner ball casts nothing

  // beside a second volume (the march over several, the outer ball alone in a grid overlapping the
  // box): the same, exactly
  const Volume second = ball_grid({16, 16, 16}, {48, 48, 48}, false, true);
  whole_scene.volumes.push_back(casting(second));
  refined_scene.volumes.push_back(casting(second));
  const MacrocellGrid second_grid(second);
  const MacrocellGrid* whole_two[] = {&whole_grid, &second_grid};
  const MacrocellGrid* opened_two[] = {&opened_grid, &second_grid};
  const ShadowCasters::FinerBox finer_two[] = {{&box_object, &box_grid}, {}};
  const ShadowCasters reference_two(whole_scene, whole_two), refined_two(refined_scene, opened_two, finer_two);
  for (int n = 0; n < 2000; ++n) {
    const Vec3 via = Vec3{20.0f / 48, 20.0f / 48, 20.0f / 48} + Vec3{u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f} * 0.5f;
    const Vec3 dir = normalize(Vec3{u(rng) - 0.5f, u(rng) - 0.5f, u(rng) - 0.5f});
    const Ray ray{via - dir * 2.0f, dir};
    const Rgb expected = reference_two.transmittance(ray, 0.0f, 4.0f), got = refined_two.transmittance(ray, 0.0f, 4.0f);
    for (int c = 0; c < 3; ++c) ASSERT_NEAR(got[c], expected[c], 1e-6f) << "two volumes, ray " << n << " channel " << c;
  }
}

// A full frame of a refined view casts from the box: the matter of a pyramid lying all in view (a ball
// shadowed by a smaller one, nothing elsewhere), exact ray-traced shadows, the frame equals the finest
// level's in memory — the eye's samples and their shadow rays alike — where shadows cast from the opened
// level do not; a preview that moves the light casts from the opened level, the next full frame from
// the box again.
TEST(ViewRefinement, AFullFrameCastsFromTheRefinedBox) {
  ScratchDir dir;
  const int size = 64;
  Volume v(ScalarType::Float32, {size, size, size}, {1.0f / size, 1.0f / size, 1.0f / size}, {-0.5f, -0.5f, -0.5f});
  const Vec3 big{0.2f, 0.2f, 0.2f}, small{0.3f, 0.28f, 0.25f};
  std::size_t n = 0;
  for (int k = 0; k < size; ++k)
    for (int j = 0; j < size; ++j)
      for (int i = 0; i < size; ++i) {
        const Vec3 p = v.origin() + v.spacing() * Vec3{static_cast<float>(i), static_cast<float>(j), static_cast<float>(k)};
        v.set_value(n++, length(p - big) < 0.08f ? 1.0f : length(p - small) < 0.04f ? 0.5f : 0.0f);
      }
  v.recompute_range();
  OmeZarrWriteOptions options;
  options.chunk = 8;
  write_ome_zarr(v, dir.file("pair.zarr"), options);
  auto scene = [&](std::uint64_t budget, bool refine) {
    nlohmann::json j = ball_scene(dir.file("pair.zarr"), budget, refine);
    const Vec3 l = normalize(big - small);
    j["lights"] = nlohmann::json::array({{{"type", "directional"}, {"direction", {l.x, l.y, l.z}}}});
    j["shadows"] = {{"technique", "ray_traced"}};
    j["camera"] = {{"eye", {0.22, 0.22, 1.2}}, {"target", {0.22, 0.22, 0.22}}, {"fov_deg", 20}, {"width", 96}, {"height", 96}};
    return build_scene(j, "");
  };
  const std::uint64_t budget = 1u << 20;  // level 1 opens
  const Scene coarse_scene = scene(budget, true);
  ASSERT_EQ(coarse_scene.volumes[0].pyramid->opened, 1);
  Renderer refined(coarse_scene);
  const FrameResult full = refined.render();
  ASSERT_EQ(full.refinement.size(), 1u);
  EXPECT_EQ(full.refinement.front().level, 0);
  EXPECT_NE(std::find(full.rebuilt.begin(), full.rebuilt.end(), "casters.refined"), full.rebuilt.end());
  const Image in_memory = Renderer(scene(0, true)).render().image;
  const Image opened_only = Renderer(scene(budget, false)).render().image;
  FailureImages keep;
  keep.add("refined", full.image, in_memory);
  const ImageDifference refined_error = compare_images(full.image, in_memory), opened_error = compare_images(opened_only, in_memory);
  EXPECT_LT(refined_error.max_abs, 1e-4) << "rmse " << refined_error.rmse;
  EXPECT_GT(opened_error.rmse, 0.01);
  EXPECT_TRUE(non_trivial(full.image));

  // a preview with the light moved builds its shadows from the opened level
  std::vector<Light> moved = coarse_scene.lights;
  moved[0].direction = normalize(moved[0].direction + Vec3{0.05f, 0.0f, 0.0f});
  FrameRequest preview;
  preview.quality = Quality::Preview;
  preview.preview_divisor = 1;
  const FrameResult p = refined.render(coarse_scene.camera, moved, preview);
  EXPECT_NE(std::find(p.rebuilt.begin(), p.rebuilt.end(), "lights.0.shadows"), p.rebuilt.end());
  EXPECT_EQ(std::find(p.rebuilt.begin(), p.rebuilt.end(), "casters.refined"), p.rebuilt.end());
  // the next full frame builds them from the box again, keeping the box and its casters
  const FrameResult again = refined.render(coarse_scene.camera, coarse_scene.lights);
  EXPECT_NE(std::find(again.rebuilt.begin(), again.rebuilt.end(), "lights.0.shadows"), again.rebuilt.end());
  EXPECT_EQ(std::find(again.rebuilt.begin(), again.rebuilt.end(), "casters.refined"), again.rebuilt.end());
  EXPECT_EQ(again.refinement.front().loaded_bytes, 0u);
  EXPECT_LT(compare_images(again.image, in_memory).max_abs, 1e-4);
}

// What reads the extinction SAT (cone shadows, the volume's ambient occlusion, the light cache) reads, in
// a full frame, a table whose cells inside the refined box are summed from the box's voxels, on the
// cells of the finest level: the balls' cone-shadowed, ambient-occluded view then equals the finest
// level's in memory (measured max 1·10⁻⁴: the table's range), where the opened level's means in those
// cells left it far (max 0.164, RMSE 0.039; on the opened level's own cells, before they were the finest
// level's, 0.214 and 0.057). A preview keeps the table; the next full frame keeps the box and its table.
TEST(ViewRefinement, TheExtinctionTableIsRefinedInTheBox) {
  ScratchDir dir;
  const std::string store = write_ball_pyramid(dir, 64);
  auto scene = [&](std::uint64_t budget) {
    nlohmann::json j = ball_view_scene(store, budget, true, "sat_cone");
    j["ambient"] = {{"technique", "sat_shells"}};
    j["light_cache"] = {{"resolution", 32}};
    return build_scene(j, "");
  };
  const std::uint64_t budget = 1u << 20;  // level 1 opens
  const Scene coarse_scene = scene(budget);
  ASSERT_EQ(coarse_scene.volumes[0].pyramid->opened, 1);
  Renderer refined(coarse_scene);
  const FrameResult full = refined.render();
  ASSERT_EQ(full.refinement.size(), 1u);
  EXPECT_EQ(full.refinement.front().level, 0);
  EXPECT_NE(std::find(full.rebuilt.begin(), full.rebuilt.end(), "sat.refined"), full.rebuilt.end());
  expect_refined_equals_memory(full.image, Renderer(scene(0)).render().image, 1e-3, "refined_sat");

  FrameRequest preview;
  preview.quality = Quality::Preview;
  preview.preview_divisor = 1;
  const FrameResult p = refined.render(coarse_scene.camera, coarse_scene.lights, preview);
  EXPECT_EQ(std::find(p.rebuilt.begin(), p.rebuilt.end(), "sat.refined"), p.rebuilt.end());
  EXPECT_EQ(std::find(p.rebuilt.begin(), p.rebuilt.end(), "sat"), p.rebuilt.end());
  // the next full frame keeps the box and its table
  const FrameResult again = refined.render(coarse_scene.camera, coarse_scene.lights);
  EXPECT_EQ(std::find(again.rebuilt.begin(), again.rebuilt.end(), "sat.refined"), again.rebuilt.end());
  EXPECT_EQ(again.refinement.front().loaded_bytes, 0u);
  EXPECT_EQ(compare_images(again.image, full.image).max_abs, 0.0);
}

// Particle ambient occlusion's density grid takes a refined box's sample where a cell centre lies in it,
// on cells laid over the pyramid's finest level (CastingVolume::extent): spheres among the balls, occluded
// by the spheres and the volume within a reach that stays in the box, equal the frame of the finest
// level in memory (measured max 0; the opened level's samples left 0.022, and a grid over the opened
// level's box 0.007). At the default reach (0.7) cones leave the box for the opened level: max 0.0011
// (0.025 before).
TEST(ViewRefinement, ParticleAmbientOcclusionSamplesTheRefinedBox) {
  ScratchDir dir;
  const std::string store = write_ball_pyramid(dir, 64);
  const std::string xyz = dir.file("spheres.xyz");
  {
    std::ofstream out(xyz);
    out << 27 << "\nspheres among the balls\n";
    for (int k = 0; k < 3; ++k)
      for (int j = 0; j < 3; ++j)
        for (int i = 0; i < 3; ++i) out << "C " << -0.28 + 0.06 * i << " " << 0.06 + 0.06 * j << " " << 0.16 + 0.06 * k << "\n";
  }
  auto scene = [&](std::uint64_t budget) {
    nlohmann::json j = ball_view_scene(store, budget, true, "none");
    j["particles"] = nlohmann::json::array({{{"file", xyz}, {"radius", 0.015}}});
    j["ambient"] = {{"technique", "particle_ao"}, {"max_distance", 0.05}};
    return build_scene(j, "");
  };
  const std::uint64_t budget = 1u << 20;  // level 1 opens
  const Scene coarse_scene = scene(budget);
  ASSERT_EQ(coarse_scene.volumes[0].pyramid->opened, 1);
  const FrameResult full = Renderer(coarse_scene).render();
  ASSERT_EQ(full.refinement.size(), 1u);
  EXPECT_EQ(full.refinement.front().level, 0);
  expect_refined_equals_memory(full.image, Renderer(scene(0)).render().image, 1e-4, "refined_particle_ao");
}

// A full frame cancelled at any moment — before, while or after its box is read — leaves nothing half
// held: the next full frame is the uncancelled frame, and the box it holds is the one the view needs.
TEST(ViewRefinement, ACancelledRefinementLeavesTheNextFrameWhole) {
  ScratchDir dir;
  const std::string store = write_ball_pyramid(dir, 64);
  const Scene scene = build_scene(ball_scene(store, 1u << 20, true), "");
  const FrameResult expected = Renderer(scene).render();
  ASSERT_EQ(expected.refinement.size(), 1u);
  int cancelled = 0;
  for (const int delay_us : {0, 200, 1000, 3000, 10000, 30000, 100000}) {
    Renderer renderer(scene);
    std::atomic<bool> flag{false};
    FrameRequest request;
    request.cancel = &flag;
    std::thread canceller([&] {
      std::this_thread::sleep_for(std::chrono::microseconds(delay_us));
      flag = true;
    });
    try {
      (void)renderer.render(scene.camera, scene.lights, request);
    } catch (const Cancelled&) {
      ++cancelled;
    }
    canceller.join();
    const FrameResult next = renderer.render();
    EXPECT_LT(compare_images(next.image, expected.image).max_abs, 1e-6) << "cancelled after " << delay_us << " µs";
    ASSERT_EQ(next.refinement.size(), 1u);
    EXPECT_EQ(next.refinement.front().held_bytes, expected.refinement.front().held_bytes);
    EXPECT_LE(renderer.refined_memory_bytes(), scene.refinement_bytes);
  }
  EXPECT_GT(cancelled, 0);  // at least the frame cancelled at once
}

// A box given up takes what casts from it along: when reading the next box fails (its chunks cut short
// on disk), the frame is an error naming the chunk, nothing refined is held, and a preview with
// ray-traced shadows (which march the casters at every lookup) draws the opened level, as a renderer
// that never refined does.
TEST(ViewRefinement, AFailedReadLeavesTheOpenedLevelsLightStructures) {
  ScratchDir dir;
  const std::string store = write_ball_pyramid(dir, 64);
  nlohmann::json j = ball_scene(store, 1u << 20, true);
  j["shadows"] = {{"technique", "ray_traced"}};
  const Scene scene = build_scene(j, "");
  Renderer refined(scene);
  ASSERT_GT(refined.render().refinement.at(0).loaded_bytes, 0u);
  // every chunk of level 0 cut to one byte: the box held stays usable, the next one cannot be read
  const std::filesystem::path level0 = std::filesystem::path(store) / "0", whole = dir.path() / "level0-whole";
  std::filesystem::copy(level0, whole, std::filesystem::copy_options::recursive);
  for (const auto& e : std::filesystem::recursive_directory_iterator(level0))
    if (e.is_regular_file() && e.path().filename().string()[0] != '.' && e.path().filename() != "zarr.json")
      std::filesystem::resize_file(e.path(), 1);
  Camera other = scene.camera;
  other.target = Vec3{0.2f, -0.1f, 0.1f};
  other.eye = other.target + Vec3{0.3f, 0.2f, 0.6f};
  j["volumes"][0]["refine"] = false;
  Renderer unrefined(build_scene(j, ""));
  // the full frame draws the opened level, with its light structures, and says which chunk failed
  const FrameResult failed = refined.render(other, scene.lights);
  ASSERT_EQ(failed.refinement.size(), 1u);
  EXPECT_NE(failed.refinement[0].error.find("chunk"), std::string::npos) << failed.refinement[0].error;
  EXPECT_EQ(failed.refinement[0].held_bytes, 0u);
  EXPECT_GT(failed.refinement[0].evicted_bytes, 0u);
  EXPECT_EQ(refined.refined_memory_bytes(), 0u);
  EXPECT_EQ(compare_images(failed.image, unrefined.render(other, scene.lights).image).max_abs, 0.0);
  EXPECT_EQ(refinement_json(failed.refinement)[0]["error"], failed.refinement[0].error);
  FrameRequest preview;
  preview.quality = Quality::Preview;
  preview.preview_divisor = 1;
  const FrameResult p = refined.render(other, scene.lights, preview);
  const Image expected = unrefined.render(other, scene.lights, preview).image;
  EXPECT_EQ(compare_images(p.image, expected).max_abs, 0.0);
  EXPECT_TRUE(non_trivial(p.image));
  // a view inside the box that failed is not read again (the chunks mended now would be read if it
  // were): it reports the same error; a view that needs another box reads it, from the mended chunks
  std::filesystem::remove_all(level0);
  std::filesystem::copy(whole, level0, std::filesystem::copy_options::recursive);
  Camera pan = other;
  pan.eye = pan.eye + Vec3{0.002f, 0, 0};
  pan.target = pan.target + Vec3{0.002f, 0, 0};
  const FrameResult again = refined.render(pan, scene.lights);
  ASSERT_EQ(again.refinement.size(), 1u);
  EXPECT_EQ(again.refinement[0].error, failed.refinement[0].error);
  EXPECT_EQ(again.refinement[0].loaded_bytes, 0u);
  const FrameResult elsewhere = refined.render(scene.camera, scene.lights);
  ASSERT_EQ(elsewhere.refinement.size(), 1u);
  EXPECT_TRUE(elsewhere.refinement[0].error.empty());
  EXPECT_GT(elsewhere.refinement[0].loaded_bytes, 0u);
}

// A volume's data replaced by another pyramid of the same grid (Renderer::apply_edit with the volume's
// structures stale, as a caller that keeps its renderer does): the box read from the first store is not
// kept for the second; the next full frame is the second store's finest level.
TEST(ViewRefinement, AnotherStoreOfTheSameGridIsReadAnew) {
  ScratchDir dir;
  const std::string first = write_ball_pyramid(dir, 64), second = write_ball_pyramid(dir, 64, 0.8f, "other.zarr");
  Renderer renderer(build_scene(ball_scene(first, 1u << 20, true), ""));
  ASSERT_GT(renderer.render().refinement.at(0).loaded_bytes, 0u);
  renderer.apply_edit(build_scene(ball_scene(second, 1u << 20, true), ""),
                      {"volumes.0.gradients", "volumes.0.minmax", "volumes.0.lut", "volumes.0.empty_space", "casters"});
  const FrameResult f = renderer.render();
  ASSERT_EQ(f.refinement.size(), 1u);
  EXPECT_GT(f.refinement.front().loaded_bytes, 0u);
  const Image expected = Renderer(build_scene(ball_scene(second, 0, true), "")).render().image;
  EXPECT_LT(compare_images(f.image, expected).max_abs, 1e-4);
}

// A view that moves past its box's margin, the budget holding the old box and the new one together:
// the new box takes the chunks both hold from the old one (read less), and the frame is still the
// finest level's in memory.
TEST(ViewRefinement, ANewBoxTakesTheOverlapFromTheBoxHeld) {
  ScratchDir dir;
  const std::string store = write_ball_pyramid(dir, 64);
  auto narrow = [&](std::uint64_t budget) { return narrow_ball_scene(store, budget, 6); };
  const Scene scene = narrow(1u << 20);
  Renderer renderer(scene);
  const FrameResult first = renderer.render();
  ASSERT_EQ(first.refinement.size(), 1u);
  ASSERT_LE(2 * first.refinement.front().held_bytes, scene.refinement_bytes);  // room for two
  const Camera moved = panned(scene.camera, {0.04f, 0.0f, 0.0f});
  const FrameResult f = renderer.render(moved, scene.lights);
  ASSERT_EQ(f.refinement.size(), 1u);
  const RefinementStats& r = f.refinement.front();
  EXPECT_GT(r.loaded_bytes, 0u) << "the pan must leave the box";
  EXPECT_GT(r.reused_bytes, 0u);
  EXPECT_EQ(r.evicted_bytes, 0u);  // the first box is kept beside the new one
  EXPECT_EQ(r.kept_bytes, first.refinement.front().held_bytes);
  Renderer fresh(scene);
  const FrameResult alone = fresh.render(moved, scene.lights);
  EXPECT_LT(r.read_bytes, alone.refinement.at(0).read_bytes);
  EXPECT_EQ(alone.refinement.at(0).reused_bytes, 0u);
  EXPECT_EQ(renderer.refined_memory_bytes(), r.held_bytes + r.kept_bytes);
  const Image in_memory = Renderer(narrow(0)).render(moved, scene.lights).image;
  EXPECT_LT(compare_images(f.image, in_memory).max_abs, 1e-4);
  EXPECT_EQ(compare_images(f.image, alone.image).max_abs, 0.0);
  // back to the first view: drawn from a box in memory (the new one covers it too), nothing read
  const FrameResult back = renderer.render(scene.camera, scene.lights);
  EXPECT_EQ(back.refinement.at(0).loaded_bytes, 0u);
  EXPECT_LT(compare_images(back.image, Renderer(narrow(0)).render().image).max_abs, 1e-4);
}

// The same pan with a budget that holds one box only: the box moves — its memory takes the new box, the
// voxels both hold moved in place — and reads only what it did not hold (before, it was given up and the
// new box read whole); the frame is still the finest level's in memory, and the budget holds.
TEST(ViewRefinement, ABoxThatMovesReadsOnlyWhatItDidNotHold) {
  ScratchDir dir;
  const std::string store = write_ball_pyramid(dir, 64);
  auto narrow = [&](std::uint64_t budget) { return narrow_ball_scene(store, budget, 7); };
  Scene scene = narrow(1u << 20);
  const std::uint64_t box = Renderer(scene).render().refinement.at(0).held_bytes;
  ASSERT_GT(box, 0u);
  scene.refinement_bytes = box * 3 / 2;  // one box, not two
  Renderer renderer(scene);
  const FrameResult first = renderer.render();
  ASSERT_EQ(first.refinement.at(0).held_bytes, box);
  const Camera moved = panned(scene.camera, {0.16f, 0.0f, 0.0f});
  const FrameResult f = renderer.render(moved, scene.lights);
  ASSERT_EQ(f.refinement.size(), 1u);
  const RefinementStats& r = f.refinement.front();
  expect_box_reused(r);
  EXPECT_EQ(r.evicted_bytes, 0u);
  EXPECT_EQ(r.kept_bytes, 0u);
  EXPECT_LE(renderer.refined_memory_bytes(), scene.refinement_bytes);
  Renderer fresh(scene);
  const FrameResult alone = fresh.render(moved, scene.lights);
  EXPECT_EQ(alone.refinement.at(0).reused_bytes, 0u);
  EXPECT_LT(r.read_bytes, alone.refinement.at(0).read_bytes);
  const Image in_memory = Renderer(narrow(0)).render(moved, scene.lights).image;
  EXPECT_LT(compare_images(f.image, in_memory).max_abs, 1e-4);
  EXPECT_LT(compare_images(f.image, alone.image).max_abs, 1e-4);
  // and back: it moves again, from the same memory
  const FrameResult back = renderer.render(scene.camera, scene.lights);
  EXPECT_GT(back.refinement.at(0).reused_bytes, 0u);
  EXPECT_LT(compare_images(back.image, Renderer(narrow(0)).render().image).max_abs, 1e-4);
  EXPECT_LE(renderer.refined_memory_bytes(), scene.refinement_bytes);
}

// The isosurface of a hidden volume is drawn from a box of its own; a pan past the box's margin moves
// it when the budget holds one box (its memory takes the new box, and only what it did not hold is
// read), and makes it lend the voxels both hold when the budget holds two (it is given up after). Either
// way the frame is a fresh renderer's (which reads the new box whole) and near the finest level's.
TEST(ViewRefinement, AnIsosurfacesOwnBoxMovesWithAPan) {
  ScratchDir dir;
  const std::string store = write_ball_pyramid(dir, 64);
  auto surface_scene = [&](std::uint64_t budget) {
    nlohmann::json j = ball_scene(store, budget, true);
    j["camera"]["fov_deg"] = 7;
    j["volumes"][0]["visible"] = false;
    j["volumes"][0].erase("transfer_function");
    j["isosurfaces"] = nlohmann::json::array({{{"volume", 0}, {"value", 0.75}, {"color", {0.9, 0.8, 0.6}}}});
    return build_scene(j, "");
  };
  Scene scene = surface_scene(1u << 20);
  const std::uint64_t box = Renderer(scene).render().refinement.at(0).held_bytes;
  ASSERT_GT(box, 0u);
  const Camera moved = panned(scene.camera, {0.16f, 0.0f, 0.0f});
  const Image in_memory = Renderer(surface_scene(0)).render(moved, scene.lights).image;
  for (const bool room_for_two : {false, true}) {
    SCOPED_TRACE(room_for_two ? "room for two boxes" : "room for one box");
    scene.refinement_bytes = room_for_two ? box * 5 / 2 : box * 3 / 2;
    Renderer renderer(scene);
    ASSERT_EQ(renderer.render().refinement.at(0).held_bytes, box);
    const FrameResult f = renderer.render(moved, scene.lights);
    ASSERT_EQ(f.refinement.size(), 1u);
    const RefinementStats& r = f.refinement.front();
    expect_box_reused(r);
    EXPECT_EQ(r.evicted_bytes, room_for_two ? box : 0u);  // a box that moves is not given up
    EXPECT_EQ(renderer.refined_memory_bytes(), r.held_bytes);
    EXPECT_LE(renderer.refined_memory_bytes(), scene.refinement_bytes);
    Renderer fresh(scene);
    const FrameResult alone = fresh.render(moved, scene.lights);
    EXPECT_EQ(alone.refinement.at(0).reused_bytes, 0u);
    EXPECT_LT(r.read_bytes, alone.refinement.at(0).read_bytes);
    FailureImages keep;
    keep.add(room_for_two ? "lent" : "moved", f.image, alone.image);
    EXPECT_LT(compare_images(f.image, alone.image).max_abs, 1e-4);
    EXPECT_LT(compare_images(f.image, in_memory).rmse, 2e-3);
    EXPECT_TRUE(non_trivial(f.image));
  }
}

// Views that move on past the boxes a budget can keep: the least recently drawn box is given up first
// (never over the budget), a view back to a box still kept reads nothing, and one back to a box given
// up reads it again.
TEST(ViewRefinement, TheLeastRecentlyDrawnBoxIsGivenUpFirst) {
  ScratchDir dir;
  const std::string store = write_ball_pyramid(dir, 64);
  nlohmann::json j = ball_scene(store, 1u << 20, true);
  j["camera"]["fov_deg"] = 5;
  Scene scene = build_scene(j, "");
  auto view = [&](float dx) {
    Camera c = scene.camera;
    c.eye = c.eye + Vec3{dx, 0, 0};
    c.target = c.target + Vec3{dx, 0, 0};
    return c;
  };
  const std::uint64_t box = Renderer(scene).render().refinement.at(0).held_bytes;
  ASSERT_GT(box, 0u);
  scene.refinement_bytes = box * 5 / 2;  // two boxes and a half: the box drawn and one kept
  Renderer renderer(scene);
  const std::array<float, 3> at{0.0f, 0.12f, 0.24f};  // views whose boxes do not overlap
  for (float dx : at) {
    const FrameResult f = renderer.render(view(dx), scene.lights);
    ASSERT_EQ(f.refinement.size(), 1u);
    EXPECT_GT(f.refinement[0].loaded_bytes, 0u);
    EXPECT_LE(renderer.refined_memory_bytes(), scene.refinement_bytes);
  }
  // A, B, C drawn: A given up when C was read, B kept
  const FrameResult b = renderer.render(view(at[1]), scene.lights);
  EXPECT_EQ(b.refinement.at(0).loaded_bytes, 0u) << "B was kept";
  const FrameResult a = renderer.render(view(at[0]), scene.lights);
  EXPECT_GT(a.refinement.at(0).loaded_bytes, 0u) << "A was given up";
  EXPECT_GT(a.refinement.at(0).evicted_bytes, 0u) << "C, the least recently drawn, makes room";
  EXPECT_LE(renderer.refined_memory_bytes(), scene.refinement_bytes);
  nlohmann::json whole = ball_scene(store, 0, true);
  whole["camera"]["fov_deg"] = 5;
  const Image expected = Renderer(build_scene(whole, "")).render(view(at[0]), scene.lights).image;
  EXPECT_LT(compare_images(a.image, expected).max_abs, 1e-4);
}

// Two refined volumes share the budget's kept boxes: the box of one, kept after the camera looked away,
// is given up for the other's new box (the frame lists both: one loaded, the other's box evicted), and
// the frame still equals the volumes' finest levels in memory.
TEST(ViewRefinement, OneVolumesNewBoxTakesTheRoomOfAnothersKeptBox) {
  ScratchDir dir;
  const std::string left_store = write_ball_pyramid(dir, 64), right_store = write_ball_pyramid(dir, 64, 0.8f, "right.zarr");
  auto two_volumes = [&](std::uint64_t budget) {
    nlohmann::json j = ball_scene(left_store, budget, true);
    nlohmann::json right = j["volumes"][0];
    right["file"] = right_store;
    right["origin"] = {1.5, -0.5, -0.5};  // 2 to the right of the left one
    j["volumes"].push_back(right);
    j["camera"]["fov_deg"] = 5;
    return build_scene(j, "");
  };
  Scene scene = two_volumes(1u << 20);
  ASSERT_TRUE(scene.volumes[0].pyramid && scene.volumes[1].pyramid) << "both opened coarser than their finest levels";
  auto view = [&](float dx) {
    Camera c = scene.camera;
    c.eye = c.eye + Vec3{dx, 0, 0};
    c.target = c.target + Vec3{dx, 0, 0};
    return c;
  };
  Camera away = scene.camera;  // looking from between them out into nothing
  away.eye = Vec3{1.0f, 0.0f, 3.0f};
  away.target = Vec3{1.0f, 0.0f, 10.0f};
  const std::uint64_t box = Renderer(scene).render(view(2.0f), scene.lights).refinement.at(0).held_bytes;
  ASSERT_GT(box, 0u);
  scene.refinement_bytes = box * 3 / 2;  // one box, not two
  Renderer renderer(scene);
  const FrameResult right = renderer.render(view(2.0f), scene.lights);
  ASSERT_EQ(right.refinement.size(), 1u);
  EXPECT_EQ(right.refinement[0].volume, 1u);
  EXPECT_GT(right.refinement[0].loaded_bytes, 0u);
  const FrameResult nothing = renderer.render(away, scene.lights);
  ASSERT_EQ(nothing.refinement.size(), 1u);
  EXPECT_EQ(nothing.refinement[0].kept_bytes, right.refinement[0].held_bytes) << "the right volume's box is kept";
  // the left volume's box is read after the right one's kept box is given up for it
  const FrameResult left = renderer.render(view(0.0f), scene.lights);
  auto entry = [&](std::size_t volume) -> const RefinementStats& {
    const auto it = std::find_if(left.refinement.begin(), left.refinement.end(), [&](const RefinementStats& s) { return s.volume == volume; });
    EXPECT_NE(it, left.refinement.end()) << "volume " << volume << " listed";
    return it == left.refinement.end() ? left.refinement.front() : *it;
  };
  ASSERT_EQ(left.refinement.size(), 2u);
  EXPECT_GT(entry(0).loaded_bytes, 0u);
  EXPECT_EQ(entry(0).held_bytes, entry(0).loaded_bytes);
  EXPECT_EQ(entry(1).evicted_bytes, right.refinement[0].held_bytes);
  EXPECT_EQ(entry(1).kept_bytes, 0u);
  EXPECT_LE(renderer.refined_memory_bytes(), scene.refinement_bytes);
  const Scene whole = two_volumes(0);
  EXPECT_LT(compare_images(left.image, Renderer(whole).render(view(0.0f), whole.lights).image).max_abs, 1e-4);
}
