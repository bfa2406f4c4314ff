// Refinement of a file without levels (data/io/volume_reduction.h, render/view_refinement.h): a file
// over the memory budget opens reduced, and full frames read a box of a finer reduction (or of the file
// itself) where the camera looks. A box against the whole reduction and the file voxel for voxel; a full
// frame against the file held whole in memory; a box held lending its slices; a file cut short after it
// was opened.
#include <gtest/gtest.h>

#include <filesystem>

#include "ball_volumes.h"
#include "image_check.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/io/volume_reduction.h"
#include "penumbra/render/renderer.h"
#include "penumbra/render/view_refinement.h"
#include "penumbra/scene_io/scene_file.h"
#include "test_scenes.h"
#include "test_volume_io_util.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

// An NRRD of `dims` in LPS with spacing (0.5, 0.75, 1.25) and origin (3, -2, 1), raw or gzip.
template <class T>
std::string write_reduction_nrrd(const ScratchDir& dir, const std::string& name, const std::array<int, 3>& dims, const std::vector<T>& voxels,
                                 const std::string& type, bool gzipped) {
  const std::string header = "type: " + type + "\ndimension: 3\nsizes: " + std::to_string(dims[0]) + " " + std::to_string(dims[1]) + " " +
                             std::to_string(dims[2]) +
                             "\nendian: little\nspace: left-posterior-superior\nspace directions: (0.5,0,0) (0,0.75,0) (0,0,1.25)\n"
                             "space origin: (3,-2,1)\nencoding: " +
                             (gzipped ? "gzip" : "raw") + "\n";
  write_file(dir.file(name), nrrd_file(header, gzipped ? gzip(to_bytes(voxels)) : to_bytes(voxels)));
  return dir.file(name);
}

VolumeLoadOptions with_budget(std::uint64_t budget) {
  VolumeLoadOptions o;
  o.memory_budget = budget;
  return o;
}

}  // namespace

// The levels of a file opened reduced are its reductions by 1, 2, 4, …; a box of any of them is that
// part of the whole reduction (block means computed the same way, bit for bit) and level 0's is the
// file's own voxels; a box held whose x and y cover the new one lends the slices both hold.
TEST(ReducedRefinement, ABoxOfAReductionIsThatPartOfTheWholeReduction) {
  ScratchDir dir;
  const std::array<int, 3> dims{37, 30, 26};  // odd edges: partial blocks
  std::vector<std::uint16_t> numbered(static_cast<std::size_t>(dims[0]) * dims[1] * dims[2]);
  for (std::size_t i = 0; i < numbered.size(); ++i) numbered[i] = static_cast<std::uint16_t>(i * 37 % 4001);
  std::vector<float> smooth(numbered.size());
  for (std::size_t i = 0; i < smooth.size(); ++i) smooth[i] = 0.001f * static_cast<float>(numbered[i]) - 0.3f;
  for (const std::string& file : {write_reduction_nrrd(dir, "u16.nrrd", dims, numbered, "uint16", false),
                                  write_reduction_nrrd(dir, "f32_gzip.nrrd", dims, smooth, "float", true)}) {
    SCOPED_TRACE(file);
    const Volume whole = load_volume(file, VolumeLoadOptions{});
    // a budget that holds a quarter of the file: reduced 2× or more
    const VolumeLoadOptions budget = with_budget(volume_held_bytes({dims[0], dims[1], dims[2]}, whole.type()) / 20);
    VolumeFileInfo info;
    const Volume opened = load_volume(file, budget, &info);
    ASSERT_LT(opened.dims()[0], dims[0]);
    const std::vector<LevelGrid> levels = reduced_level_grids(file, budget, opened);
    ASSERT_GE(levels.size(), 3u);  // at least 4× (the file, 2×, 4×, …)
    const int top = static_cast<int>(levels.size()) - 1;
    EXPECT_EQ(levels[0].dims, dims);
    EXPECT_EQ(levels.back().dims, opened.dims());
    for (int a = 0; a < 3; ++a) {
      EXPECT_FLOAT_EQ(levels[0].spacing[a], whole.spacing()[a]);
      EXPECT_FLOAT_EQ(levels[0].origin[a], whole.origin()[a]);
      EXPECT_NEAR(levels.back().origin[a], opened.origin()[a], 1e-5f);
      EXPECT_FLOAT_EQ(levels.back().spacing[a], opened.spacing()[a]);
    }
    EXPECT_TRUE(reduced_level_grids(file, VolumeLoadOptions{}, whole).size() == 1u) << "the file itself is its level 0";
    auto check_box = [&](int level, const Volume& reference, const std::array<std::int64_t, 3>& lo, const std::array<std::int64_t, 3>& hi) {
      WindowRead read;
      const Volume box = load_reduced_box(file, budget, levels[0], level, lo, hi, &read);
      ASSERT_EQ(box.dims(), (std::array<int, 3>{static_cast<int>(hi[0] - lo[0]), static_cast<int>(hi[1] - lo[1]), static_cast<int>(hi[2] - lo[2])}));
      for (int a = 0; a < 3; ++a)
        EXPECT_NEAR(box.origin()[a], reference.origin()[a] + static_cast<float>(lo[static_cast<std::size_t>(a)]) * reference.spacing()[a], 1e-4f);
      EXPECT_EQ(box.opacity_length(), opened.opacity_length());
      for (int k = 0; k < box.dims()[2]; ++k)
        for (int j = 0; j < box.dims()[1]; ++j)
          for (int i = 0; i < box.dims()[0]; ++i)
            ASSERT_EQ(box.value(i, j, k), reference.value(i + static_cast<int>(lo[0]), j + static_cast<int>(lo[1]), k + static_cast<int>(lo[2])))
                << "level " << level << " voxel " << i << "," << j << "," << k;
      EXPECT_GT(read.bytes_read, 0u);
    };
    const auto& d = opened.dims();
    check_box(top, opened, {0, 0, 0}, {d[0], d[1], d[2]});
    check_box(top, opened, {1, 2, 1}, {d[0] - 1, 5, d[2]});
    check_box(0, whole, {3, 5, 7}, {29, 11, 20});
    check_box(0, whole, {dims[0] - 2, 0, dims[2] - 3}, {dims[0], dims[1], dims[2]});
    // a box held that covers the new one in x and y: the slices both hold are copied, the rest read
    const std::array<std::int64_t, 3> lo{4, 3, 6}, hi{30, 25, 22};
    const Volume before = load_reduced_box(file, budget, levels[0], 0, {2, 1, 0}, {33, 28, 14});
    const HeldBox held{{2, 1, 0}, {33, 28, 14}, &before};
    WindowRead fresh_read, lent_read;
    const Volume fresh = load_reduced_box(file, budget, levels[0], 0, lo, hi, &fresh_read);
    const Volume lent = load_reduced_box(file, budget, levels[0], 0, lo, hi, &lent_read, &held);
    for (std::size_t n = 0; n < fresh.voxel_count(); ++n) ASSERT_EQ(lent.value(n), fresh.value(n)) << "voxel " << n;
    EXPECT_EQ(lent.min_value(), fresh.min_value());
    EXPECT_EQ(lent.max_value(), fresh.max_value());
    EXPECT_EQ(lent_read.bytes_reused, std::uint64_t{8} * 26 * 22 * scalar_size(whole.type()));  // slices 6..13
    EXPECT_EQ(fresh_read.bytes_reused, 0u);
    if (file.find("gzip") == std::string::npos) {
      EXPECT_LT(lent_read.bytes_read, fresh_read.bytes_read);
    }
    // one that does not cover x: everything is read
    const Volume narrow = load_reduced_box(file, budget, levels[0], 0, {10, 1, 0}, {33, 28, 14});
    const HeldBox narrow_held{{10, 1, 0}, {33, 28, 14}, &narrow};
    WindowRead narrow_read;
    (void)load_reduced_box(file, budget, levels[0], 0, lo, hi, &narrow_read, &narrow_held);
    EXPECT_EQ(narrow_read.bytes_reused, 0u);
    // a box held that gives its voxels up to a new box of its size: moved in place, the slices both hold
    // (when x and y stay) not read; moved across in x, every slice read into the same memory
    for (const std::array<std::int64_t, 3>& by : std::vector<std::array<std::int64_t, 3>>{{0, 0, 5}, {0, 0, -3}, {2, -1, 4}}) {
      const std::array<std::int64_t, 3> held_lo{4, 3, 6}, held_hi{30, 25, 18};
      const std::array<std::int64_t, 3> to_lo{held_lo[0] + by[0], held_lo[1] + by[1], held_lo[2] + by[2]};
      const std::array<std::int64_t, 3> to_hi{held_hi[0] + by[0], held_hi[1] + by[1], held_hi[2] + by[2]};
      Volume storage = load_reduced_box(file, budget, levels[0], 0, held_lo, held_hi);
      const std::byte* memory = storage.data();
      HeldBox moving{held_lo, held_hi, &storage, &storage};
      WindowRead to_read, again_read;
      const Volume again = load_reduced_box(file, budget, levels[0], 0, to_lo, to_hi, &again_read);
      const Volume moved = load_reduced_box(file, budget, levels[0], 0, to_lo, to_hi, &to_read, &moving);
      EXPECT_EQ(moved.data(), memory);
      for (std::size_t n = 0; n < again.voxel_count(); ++n) ASSERT_EQ(moved.value(n), again.value(n)) << "voxel " << n;
      for (int a = 0; a < 3; ++a) EXPECT_EQ(moved.origin()[a], again.origin()[a]);
      EXPECT_EQ(moved.min_value(), again.min_value());
      EXPECT_EQ(moved.max_value(), again.max_value());
      if (by[0] == 0 && by[1] == 0) {
        EXPECT_EQ(to_read.bytes_reused, std::uint64_t(12 - std::abs(by[2])) * 26 * 22 * scalar_size(whole.type()));
        if (file.find("gzip") == std::string::npos) {
          EXPECT_LT(to_read.bytes_read, again_read.bytes_read);
        }
      } else {
        EXPECT_EQ(to_read.bytes_reused, 0u);
      }
    }
    EXPECT_THROW(load_reduced_box(file, budget, levels[0], 0, {0, 0, 0}, {dims[0] + 1, 4, 4}), Error);
    EXPECT_THROW(load_reduced_box(file, budget, levels[0], 0, {4, 0, 0}, {4, 4, 4}), Error);
  }
}

namespace {

// The balls (ball_volumes.h) in an NRRD.
std::string write_ball_nrrd(const ScratchDir& dir, int size, const std::string& name = "ball.nrrd", float small_density = 0.5f) {
  const Volume v = ball_volume(size, small_density);
  const std::vector<float> voxels(v.data_as<float>(), v.data_as<float>() + v.voxel_count());
  const std::string s = std::to_string(v.spacing().x);
  const std::string header = "type: float\ndimension: 3\nsizes: " + std::to_string(size) + " " + std::to_string(size) + " " +
                             std::to_string(size) + "\nendian: little\nspace: left-posterior-superior\nspace directions: (" + s + ",0,0) (0," +
                             s + ",0) (0,0," + s + ")\nspace origin: (-0.5,-0.5,-0.5)\nencoding: raw\n";
  write_file(dir.file(name), nrrd_file(header, to_bytes(voxels)));
  return dir.file(name);
}

nlohmann::json ball_file_scene(const std::string& file, std::uint64_t budget, bool refine) {
  return ball_view_scene(file, budget, refine, "ray_traced");
}

}  // namespace

// An NRRD over the budget opens reduced 2×; a full frame of a close view reads a box of the file itself
// and equals the frame of the file held whole in memory (the eye pass and its exact shadow rays march the same
// voxels on the same lattice), where the reduced volume alone is far from it. The volume moved by the
// scene's `origin` moves its box with it. The file cut short after it was opened: the full frame draws
// the reduced volume, names the file and does not read again for views inside that box.
TEST(ReducedRefinement, AFullFrameOfAFileReadReducedIsTheFilesOwn) {
  ScratchDir dir;
  const std::string file = write_ball_nrrd(dir, 64);
  const std::uint64_t budget = 1u << 20;  // 64³ float32 is 1 MiB with its macrocells over: 32³ opens
  const Scene scene = build_scene(ball_file_scene(file, budget, true), "");
  ASSERT_EQ(scene.volumes[0].volume->dims()[0], 32);
  ASSERT_TRUE(scene.volumes[0].pyramid);
  EXPECT_EQ(scene.volumes[0].pyramid->opened, 1);
  EXPECT_EQ(scene.volumes[0].pyramid->levels.size(), 2u);
  Renderer refined(scene);
  const FrameResult full = refined.render();
  ASSERT_EQ(full.refinement.size(), 1u);
  const RefinementStats& s = full.refinement.front();
  EXPECT_EQ(s.opened_level, 1);
  EXPECT_EQ(s.level, 0);
  EXPECT_GT(s.read_bytes, 0u);
  EXPECT_LE(s.held_bytes, scene.refinement_bytes);
  EXPECT_LT(s.dims[0] * s.dims[1] * s.dims[2], 64 * 64 * 64);
  const Image in_memory = Renderer(build_scene(ball_file_scene(file, 0, true), "")).render().image;
  const Image opened_only = Renderer(build_scene(ball_file_scene(file, budget, false), "")).render().image;
  FailureImages keep;
  keep.add("refined", full.image, in_memory);
  keep.add("opened", opened_only, in_memory);
  EXPECT_LT(compare_images(full.image, in_memory).max_abs, 1e-4);
  EXPECT_GT(compare_images(opened_only, in_memory).rmse, 0.01);
  EXPECT_TRUE(non_trivial(full.image));
  EXPECT_FALSE(build_scene(ball_file_scene(file, budget, false), "").volumes[0].pyramid);
  EXPECT_FALSE(build_scene(ball_file_scene(file, 0, true), "").volumes[0].pyramid) << "a file that fits is not reduced";

  // moved by the scene: the box moves with the volume
  auto moved = [&](std::uint64_t b) {
    nlohmann::json j = ball_file_scene(file, b, true);
    j["volumes"][0]["origin"] = {-0.4, -0.5, -0.5};
    return build_scene(j, "");
  };
  const FrameResult moved_full = Renderer(moved(budget)).render();
  ASSERT_EQ(moved_full.refinement.size(), 1u);
  const Image moved_in_memory = Renderer(moved(0)).render().image;
  keep.add("moved", moved_full.image, moved_in_memory);
  EXPECT_LT(compare_images(moved_full.image, moved_in_memory).max_abs, 1e-4);
  EXPECT_GT(compare_images(moved_full.image, full.image).rmse, 0.01);

  // cut short after opening: the reduced volume is drawn, the error names the file
  Renderer cut(scene);
  std::filesystem::resize_file(file, 4096);
  const FrameResult broken = cut.render();
  ASSERT_EQ(broken.refinement.size(), 1u);
  EXPECT_NE(broken.refinement.front().error.find("ball.nrrd"), std::string::npos) << broken.refinement.front().error;
  EXPECT_EQ(broken.refinement.front().held_bytes, 0u);
  keep.add("cut", broken.image, opened_only);
  EXPECT_EQ(compare_images(broken.image, opened_only).max_abs, 0.0);
  const FrameResult again = cut.render();
  ASSERT_EQ(again.refinement.size(), 1u);
  EXPECT_EQ(again.refinement.front().error, broken.refinement.front().error);
  EXPECT_EQ(again.refinement.front().read_bytes, 0u);
}

// A time series of files read reduced: each step is refined from its own file, and a step edited to
// another reads that step's box anew (the box of the step before is not taken for it).
TEST(ReducedRefinement, EachStepOfASeriesIsRefinedFromItsFile) {
  ScratchDir dir;
  const std::string first = write_ball_nrrd(dir, 64, "step_0.nrrd", 0.5f), second = write_ball_nrrd(dir, 64, "step_1.nrrd", 0.9f);
  auto series = [&](std::uint64_t budget, int time) {
    nlohmann::json j = ball_file_scene(first, budget, true);
    j["volumes"][0].erase("file");
    j["volumes"][0]["files"] = {first, second};
    j["time"] = time;
    return build_scene(j, "");
  };
  const std::uint64_t budget = 1u << 20;
  const Scene step0 = series(budget, 0);
  ASSERT_TRUE(step0.volumes[0].pyramid);
  Renderer renderer(step0);
  const FrameResult f0 = renderer.render();
  ASSERT_EQ(f0.refinement.size(), 1u);
  EXPECT_EQ(f0.refinement.front().level, 0);
  FailureImages keep;
  const Image expected0 = Renderer(series(0, 0)).render().image;
  keep.add("step0", f0.image, expected0);
  EXPECT_LT(compare_images(f0.image, expected0).max_abs, 1e-4);
  renderer.apply_edit(series(budget, 1), {"volumes.0.gradients", "volumes.0.minmax", "volumes.0.lut", "volumes.0.empty_space", "casters"});
  const FrameResult f1 = renderer.render();
  ASSERT_EQ(f1.refinement.size(), 1u);
  EXPECT_GT(f1.refinement.front().loaded_bytes, 0u) << "the next step's box is read from its own file";
  const Image expected1 = Renderer(series(0, 1)).render().image;
  keep.add("step1", f1.image, expected1);
  EXPECT_LT(compare_images(f1.image, expected1).max_abs, 1e-4);
  EXPECT_GT(compare_images(expected1, expected0).rmse, 0.005) << "the steps differ where the camera looks";
}

namespace {

// The balls' isosurface at 0.75 (the volume hidden), seen close.
nlohmann::json ball_isosurface_scene(const std::string& file, std::uint64_t budget, bool refine) {
  nlohmann::json j = ball_file_scene(file, budget, refine);
  j["volumes"][0]["visible"] = false;
  j["volumes"][0].erase("transfer_function");
  j["isosurfaces"] = nlohmann::json::array({{{"volume", 0}, {"value", 0.75}, {"color", {0.9, 0.8, 0.6}}}});
  j["shadows"] = {{"technique", "none"}};
  return j;
}

// A refined frame near the frame in memory where the opened level alone is far from it (the images kept
// under `label` when either fails).
void expect_refined_near_memory(const Image& refined, const Image& in_memory, const Image& opened_only, const std::string& label) {
  FailureImages keep;
  keep.add(label + "_refined", refined, in_memory);
  keep.add(label + "_opened", opened_only, in_memory);
  const ImageDifference refined_error = compare_images(refined, in_memory), opened_error = compare_images(opened_only, in_memory);
  EXPECT_LT(refined_error.rmse, 2e-3) << refined_error.rmse << " against the reduced surface's " << opened_error.rmse;
  EXPECT_GT(opened_error.rmse, 0.01);
  EXPECT_TRUE(non_trivial(refined));
}

}  // namespace

// The isosurface of a hidden volume opened reduced is drawn, in full frames, from a box of the file
// where the camera looks (its own box: the volume draws none) and from the reduced volume around it; the
// frame is near the file's in memory where the reduced surface alone is not; a preview extracts from the
// reduced volume; backing away gives the box up. (With the reduced surface not kept out of the box, its
// points there compete with the box's and this fails.)
TEST(ReducedRefinement, AnIsosurfaceIsExtractedFromTheRefinedBox) {
  ScratchDir dir;
  const std::string file = write_ball_nrrd(dir, 64);
  const std::uint64_t budget = 1u << 20;
  const Scene scene = build_scene(ball_isosurface_scene(file, budget, true), "");
  ASSERT_TRUE(scene.volumes[0].pyramid);
  Renderer refined(scene);
  const FrameResult full = refined.render();
  ASSERT_EQ(full.refinement.size(), 1u);
  const RefinementStats& s = full.refinement.front();
  EXPECT_EQ(s.level, 0);
  EXPECT_GT(s.held_bytes, 0u);
  EXPECT_LE(s.held_bytes, scene.refinement_bytes);
  EXPECT_EQ(refined.refined_memory_bytes(), s.held_bytes);
  EXPECT_NE(std::find(full.rebuilt.begin(), full.rebuilt.end(), "volumes.0.refined_hierarchy"), full.rebuilt.end());
  const Image in_memory = Renderer(build_scene(ball_isosurface_scene(file, 0, true), "")).render().image;
  const Image opened_only = Renderer(build_scene(ball_isosurface_scene(file, budget, false), "")).render().image;
  expect_refined_near_memory(full.image, in_memory, opened_only, "points");
  // a preview extracts from the reduced volume
  FrameRequest preview;
  preview.quality = Quality::Preview;
  preview.preview_divisor = 1;
  const FrameResult p = refined.render(preview);
  Renderer unrefined(build_scene(ball_isosurface_scene(file, budget, false), ""));
  (void)unrefined.render();
  EXPECT_EQ(compare_images(p.image, unrefined.render(preview).image).max_abs, 0.0);
  // backing away: the box is given up
  Camera far = scene.camera;
  far.eye = far.target + (far.eye - far.target) * 40.0f;
  const FrameResult backed = refined.render(far, scene.lights);
  ASSERT_EQ(backed.refinement.size(), 1u);
  EXPECT_EQ(backed.refinement.front().evicted_bytes, s.held_bytes);
  EXPECT_EQ(refined.refined_memory_bytes(), 0u);
}

// The exact reference, `raycast`, is refined too: each eye ray meets the box's surface inside the box
// and the reduced volume's before and behind it (exact shadow rays the same), so the frame is near the
// file's in memory where the reduced surface alone is far from it; a preview casts the reduced volume's.
// (Lit as in the test above: a shadow ray leaving the box meets the reduced surface beyond it.)
TEST(ReducedRefinement, ARaycastIsosurfaceMeetsTheRefinedBox) {
  ScratchDir dir;
  const std::string file = write_ball_nrrd(dir, 64);
  for (const char* technique : {"none", "ray_traced"}) {
    SCOPED_TRACE(technique);
    auto raycast_scene = [&](std::uint64_t budget, bool refine) {
      nlohmann::json j = ball_isosurface_scene(file, budget, refine);
      j["isosurfaces"][0]["method"] = "raycast";
      j["shadows"] = {{"technique", technique}};
      j["lights"][0]["direction"] = {0.6, -1.0, -0.3};
      return build_scene(j, "");
    };
    const Scene scene = raycast_scene(1u << 20, true);
    Renderer refined(scene);
    const FrameResult full = refined.render();
    ASSERT_EQ(full.refinement.size(), 1u);
    EXPECT_EQ(full.refinement.front().level, 0);
    EXPECT_GT(full.refinement.front().held_bytes, 0u);
    const Image in_memory = Renderer(raycast_scene(0, true)).render().image;
    Renderer unrefined(raycast_scene(1u << 20, false));
    const Image opened_only = unrefined.render().image;
    expect_refined_near_memory(full.image, in_memory, opened_only, technique);
    FrameRequest preview;
    preview.quality = Quality::Preview;
    preview.preview_divisor = 1;
    EXPECT_EQ(compare_images(refined.render(preview).image, unrefined.render(preview).image).max_abs, 0.0);
  }
}

// A visible volume and its isosurface: the isosurface takes the volume's refined box (one box read,
// one refinement entry; the hierarchy over it, like the opened level's, is not counted in the budget).
TEST(ReducedRefinement, AnIsosurfaceSharesTheVisibleVolumesBox) {
  ScratchDir dir;
  const std::string file = write_ball_nrrd(dir, 64);
  auto both = [&](std::uint64_t budget) {
    nlohmann::json j = ball_file_scene(file, budget, true);
    j["isosurfaces"] = nlohmann::json::array({{{"volume", 0}, {"value", 0.75}, {"color", {0.9, 0.8, 0.6}}}});
    j["shadows"] = {{"technique", "none"}};
    return build_scene(j, "");
  };
  const Scene scene = both(1u << 20);
  Renderer renderer(scene);
  const FrameResult full = renderer.render();
  ASSERT_EQ(full.refinement.size(), 1u);
  EXPECT_EQ(full.refinement.front().level, 0);
  EXPECT_NE(std::find(full.rebuilt.begin(), full.rebuilt.end(), "volumes.0.refined_hierarchy"), full.rebuilt.end());
  EXPECT_EQ(renderer.refined_memory_bytes(), full.refinement.front().held_bytes);
  const Image in_memory = Renderer(both(0)).render().image;
  FailureImages keep;
  keep.add("both", full.image, in_memory);
  EXPECT_LT(compare_images(full.image, in_memory).rmse, 2e-3);
  // the same view again: nothing read, the hierarchy kept
  const FrameResult again = renderer.render();
  EXPECT_EQ(std::find(again.rebuilt.begin(), again.rebuilt.end(), "volumes.0.refined_hierarchy"), again.rebuilt.end());
  EXPECT_EQ(again.refinement.at(0).loaded_bytes, 0u);
}

// The shadows of a refined isosurface are cast by the same surface as the one drawn: the light pass
// (paper 002 §4) extracts the surface from the light inside the refined box from the box, and exact
// shadow rays meet the box's surface inside it. The frame with its shadows equals the file's in memory
// (at 384²: light pass 53 dB, rays 96 dB) where casters of the reduced volume alone shadow the finer
// surface by the coarser one (blotches where the coarser lies in front: 24 and 31 dB). A preview draws
// the opened level's surface and casts from it; backing away gives the box up.
TEST(ReducedRefinement, AnIsosurfacesShadowsAreCastFromTheRefinedBox) {
  ScratchDir dir;
  const std::string file = write_ball_nrrd(dir, 64);
  for (const char* technique : {"light_pass", "ray_traced"}) {
    SCOPED_TRACE(technique);
    auto scene = [&](std::uint64_t budget, bool refine = true) {
      nlohmann::json j = ball_isosurface_scene(file, budget, refine);
      j["shadows"] = {{"technique", technique}};
      if (std::string(technique) == "light_pass") j["shadows"]["resolution"] = 512;
      j["lights"][0]["direction"] = {0.6, -1.0, -0.3};  // from the side: the terraces of the voxel ball cast
      return build_scene(j, "");
    };
    Renderer refined(scene(1u << 20));
    const FrameResult full = refined.render();
    ASSERT_EQ(full.refinement.size(), 1u);
    EXPECT_EQ(full.refinement.front().level, 0);
    const Image in_memory = Renderer(scene(0)).render().image;
    FailureImages keep;
    keep.add(technique, full.image, in_memory);
    const ImageDifference error = compare_images(full.image, in_memory);
    EXPECT_LT(error.rmse, 2e-3) << error.rmse;
    EXPECT_TRUE(non_trivial(full.image));
    if (std::string(technique) == "light_pass") {
      EXPECT_GT(full.isosurface.light_points, 0u);
    }
    // a preview draws the opened level's surface, and its shadows are cast by the opened level too
    // (the box's finer surface lies in front of the coarser one in places and would shadow it)
    FrameRequest preview;
    preview.quality = Quality::Preview;
    preview.preview_divisor = 1;
    const FrameResult p = refined.render(preview);
    Renderer unrefined(scene(1u << 20, false));
    (void)unrefined.render();
    EXPECT_EQ(compare_images(p.image, unrefined.render(preview).image).max_abs, 0.0);
    // backing away gives the box up: the reduced volume alone casts again
    Camera far = refined.scene().camera;
    far.eye = far.target + (far.eye - far.target) * 40.0f;
    const FrameResult backed = refined.render(far, refined.scene().lights);
    ASSERT_EQ(backed.refinement.size(), 1u);
    EXPECT_GT(backed.refinement.front().evicted_bytes, 0u);
    EXPECT_EQ(compare_images(backed.image, unrefined.render(far, unrefined.scene().lights).image).max_abs, 0.0);
    // The view above casts no shadow (the big ball alone is above 0.75, lit from the side). At 0.4 the
    // small ball joins the surface and, lit from behind it, shadows the big one in view: the refined frame
    // is near the frame in memory and far from the frame without shadows.
    auto shadowed = [&](std::uint64_t budget, const char* shadows) {
      nlohmann::json j = ball_isosurface_scene(file, budget, true);
      j["isosurfaces"][0]["value"] = 0.4;
      j["shadows"] = {{"technique", shadows}};
      j["lights"][0]["direction"] = {0.35, -0.2, -0.1};
      return Renderer(build_scene(j, "")).render().image;
    };
    const Image with_shadows = shadowed(0, technique), without = shadowed(0, "none");
    const double shadow_rmse = compare_images(with_shadows, without).rmse;
    EXPECT_GT(shadow_rmse, 0.05) << "the small ball's shadow in view";
    const double cast_rmse = compare_images(shadowed(1u << 20, technique), with_shadows).rmse;
    EXPECT_LT(cast_rmse, 0.1 * shadow_rmse) << cast_rmse << " against the shadow's own " << shadow_rmse;
  }
}
