// `mpirun -np N penumbra render` (distributed/distributed_frame.h): the same executable on N ranks,
// oversubscribed on this machine's cores. Each N gives the brick loop's frame (`render --slabs N`) bit
// for bit — the same slabs, the same per-pixel compositing, and the CSSM and the classic map built per
// rank and combined are the whole volume's maps (the classic map up to rounding at its 0.5 threshold,
// none on this shell); the deep shadow map combined over the ranks is the whole one up to the rounding
// of its products (above 100 dB) — so N = 1 is the single-process frame, and N > 1 differs
// from it only below the early-termination bound (test_volume_slabs.cpp). Bad launches stop every rank
// with the same message, and none hangs (each run is under `timeout`).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>

#include "cli_run.h"
#include "image_check.h"
#include "penumbra/core/cutoffs.h"
#include "penumbra/core/image_io.h"
#include "penumbra/distributed/brick_reading.h"
#include "penumbra/distributed/icet_compositor.h"
#include "penumbra/data/io/zarr_writer.h"
#include "penumbra/data/procedural.h"
#include "test_scenes.h"
#include "test_volume_io_util.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

bool have_mpirun() { return std::system("command -v mpirun > /dev/null 2>&1") == 0; }

// The rank counts a test runs: all of `counts` in the release suite; under the sanitizers
// (PENUMBRA_TEST_SCALE=sanitize) only 3, or the nearest count below it. The sanitizers look for memory
// errors, which three ranks (an uneven split with a middle brick) meet on the same code paths as the
// other counts, while every rank of every launch pays their start-up.
std::vector<int> rank_counts(const std::vector<int>& counts) {
  if (!sanitize_scale()) return counts;
  int chosen = counts.front();
  for (const int np : counts)
    if (np <= 3) chosen = np;
  return {chosen};
}

// `penumbra ARGS` on `np` ranks. Open MPI refuses root unless told; leak checking is off in the ranks
// (Open MPI's own allocations at exit are not ours; the single-process tests check penumbra's).
CliRun mpirun_cli(int np, const std::string& args) {
  ::setenv("OMPI_ALLOW_RUN_AS_ROOT", "1", 1);
  ::setenv("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1", 1);
  const std::string launch = "timeout 300 mpirun --oversubscribe --bind-to none -np " + std::to_string(np) +
                             " -x ASAN_OPTIONS=detect_leaks=0 ";
  return penumbra_cli_with_launcher(launch, args);
}

std::size_t count(const std::string& text, const std::string& needle) {
  std::size_t n = 0;
  for (std::size_t at = text.find(needle); at != std::string::npos; at = text.find(needle, at + needle.size())) ++n;
  return n;
}

// A hollow shell lit from above (+z) and seen from below the side: its upper half, in the upper ranks'
// slabs, shadows its lower half, in the lower ranks'.
nlohmann::json shell_scene() {
  nlohmann::json j = volume_scene({{"name", "hollow-sphere"}, {"size", 32}}, step_tf(0.5, 0.9, 0.8, 0.6));
  j["lights"] = nlohmann::json::array({{{"type", "directional"}, {"direction", {0.1, 0.2, -1.0}}}});
  j["shadows"] = {{"technique", "cssm"}, {"resolution", 128}};
  j["background"] = {0.1, 0.15, 0.2};
  j["camera"] = {{"width", 64}, {"height", 56}, {"eye", {1.6, 0.4, -1.2}}, {"target", {0.0, 0.0, 0.0}}};
  return j;
}

// Spheres without a volume, split over the ranks by the z of their centres, lit from above (+z): the
// upper ranks' spheres shadow the lower ranks' and the floor (below every sphere, held by every rank).
// Two objects, the second casting no shadow.
nlohmann::json spheres_scene() {
  nlohmann::json j;
  j["particles"] = nlohmann::json::array(
      {{{"procedural", {{"name", "random-spheres"}, {"count", 70}, {"radius", 0.07}, {"seed", 3}}}},
       {{"procedural", {{"name", "random-spheres"}, {"count", 12}, {"radius", 0.05}, {"seed", 4}}}, {"origin", {0.3, -0.2, 0.1}},
        {"casts_shadows", false}}});
  j["planes"] = nlohmann::json::array({{{"point", {0, 0, -0.65}}, {"normal", {0, 0, 1}}, {"size", 3}}});
  j["lights"] = nlohmann::json::array({{{"type", "directional"}, {"direction", {0.2, 0.3, -1.0}}}});
  j["shadows"] = {{"technique", "issm"}, {"resolution", 256}, {"rings", 1}};
  j["background"] = {0.1, 0.15, 0.2};
  j["camera"] = {{"width", 72}, {"height", 60}, {"eye", {1.7, -1.2, 0.9}}, {"target", {0.0, 0.0, -0.1}}};
  return j;
}

}  // namespace

// A particle scene (distributed/sphere_split.h): each rank renders its share of the spheres, the
// implicit sphere shadow map keeps the nearest of the ranks' candidates per texel, so it is the whole
// map and every N gives the single-process frame bit for bit; the particle AO adds the ranks' splatted
// densities in doubles where one process adds floats (a last-bit difference in a cell's density, which
// may move a cone's occlusion across a 1/255 step), so above one rank it is held to 50 dB. Without the
// combined map the lower ranks' spheres and the floor come out lit (below 30 dB).
TEST(MpiRender, OneToFourRanksSplitTheSpheresAndGiveTheSingleProcessFrame) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun not installed (scripts/install-deps.sh installs Open MPI)";
  ScratchDir dir;
  std::ofstream(dir.file("issm.json")) << spheres_scene().dump();
  nlohmann::json soft = spheres_scene();
  soft["shadows"] = {{"technique", "issm"}, {"resolution", 256}, {"rings", -1}, {"soft_radius", 0.05}};  // automatic rings
  std::ofstream(dir.file("soft.json")) << soft.dump();
  nlohmann::json cssm = spheres_scene();
  cssm["shadows"] = {{"technique", "cssm"}, {"resolution", 256}};  // the first stop's minimum over the ranks
  std::ofstream(dir.file("cssm.json")) << cssm.dump();
  nlohmann::json ao = spheres_scene();
  ao["ambient"] = {{"technique", "particle_ao"}, {"grid", 32}};
  std::ofstream(dir.file("ao.json")) << ao.dump();
  for (const std::string scene : {"issm", "soft", "cssm", "ao"}) {
    SCOPED_TRACE(scene);
    const std::string scene_file = quote(dir.file(scene + ".json"));
    const CliRun whole = penumbra_cli("render " + scene_file + " -o " + quote(dir.file(scene + "_whole.pfm")));
    ASSERT_EQ(whole.status, 0) << whole.err;
    const Image reference = read_image(dir.file(scene + "_whole.pfm"));
    ASSERT_TRUE(non_trivial(reference));
    for (const int np : rank_counts({1, 2, 3, 4})) {
      SCOPED_TRACE(np);
      const std::string n = std::to_string(np);
      const std::string out = dir.file(scene + "_np" + n + ".pfm");
      const CliRun ranks = mpirun_cli(np, "render " + scene_file + " -o " + quote(out) + " --stats " + quote(dir.file("stats" + n + ".json")));
      ASSERT_EQ(ranks.status, 0) << ranks.out << ranks.err;
      const Image distributed = read_image(out);
      FailureImages keep;
      keep.add(scene + "_np" + n, distributed, reference);
      const ImageDifference d = compare_images(distributed, reference);
      if (scene == "ao" && np > 1) {
        EXPECT_GT(d.psnr, 50.0);
      } else {
        EXPECT_TRUE(distributed.pixels() == reference.pixels()) << "psnr " << d.psnr << ", max " << d.max_abs;
      }
      const nlohmann::json stats = nlohmann::json::parse(slurp(dir.file("stats" + n + ".json")));
      EXPECT_EQ(stats["split"], "spheres by z order");
      ASSERT_EQ(stats["ranks"].size(), static_cast<std::size_t>(np));
      std::size_t spheres = 0;
      for (const auto& r : stats["ranks"]) {
        spheres += r["spheres"].get<std::size_t>();
        EXPECT_NEAR(r["spheres"].get<double>(), 82.0 / np, 1.0) << r.dump();  // equal runs
        EXPECT_EQ(r["shadow_bytes_sent"].get<double>() > 0, np > 1) << r.dump();
      }
      EXPECT_EQ(spheres, 82u);
    }
  }
}

TEST(MpiRender, OneToFourRanksGiveTheBrickLoopsFrameBitForBit) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun not installed (scripts/install-deps.sh installs Open MPI)";
  ScratchDir dir;
  std::ofstream(dir.file("shell.json")) << shell_scene().dump();
  nlohmann::json deep = shell_scene();
  deep["shadows"] = {{"technique", "deep_shadow_map"}, {"resolution", 96}, {"nodes", 4}};  // built per rank, combined
  std::ofstream(dir.file("deep.json")) << deep.dump();
  deep["shadows"]["dsm_layout"] = "shared_depth";
  std::ofstream(dir.file("deep_shared.json")) << deep.dump();
  nlohmann::json classic = shell_scene();
  classic["shadows"] = {{"technique", "shadow_map"}, {"resolution", 128}, {"pcf", 1}};  // built per rank, combined
  classic["lights"] = nlohmann::json::array({{{"type", "point"}, {"position", {0.2, 0.3, 1.5}}}});
  std::ofstream(dir.file("classic.json")) << classic.dump();
  // opaque surfaces, held whole by every rank and shown by the rank whose slab holds their visible point
  nlohmann::json surfaces = shell_scene();
  surfaces["planes"] = nlohmann::json::array({{{"point", {-0.7, 0, 0}}, {"normal", {1, 0, 0}}, {"size", 3}}});  // behind the shell
  surfaces["particles"] = nlohmann::json::array(
      {{{"procedural", {{"name", "random-spheres"}, {"count", 10}, {"radius", 0.08}, {"seed", 5}}}, {"origin", {0.0, 0.1, 0.2}}}});
  std::ofstream(dir.file("surfaces.json")) << surfaces.dump();
  // the extinction SAT summed over the ranks, read by cone shadows and ambient occlusion
  nlohmann::json sat = shell_scene();
  sat["shadows"] = {{"technique", "sat_cone"}};
  sat["ambient"] = {{"technique", "sat_shells"}};
  sat["light_cache"] = {{"resolution", 32}};
  std::ofstream(dir.file("sat.json")) << sat.dump();
  // an isosurface of a hidden volume before a wall, under its light pass: every rank extracts it whole
  // and shows the pixels whose visible point lies in its slab
  nlohmann::json isosurface = surfaces;
  isosurface.erase("particles");
  isosurface["volumes"][0]["visible"] = false;
  isosurface["isosurfaces"] = nlohmann::json::array({{{"volume", 0}, {"value", 0.5}}});
  isosurface["shadows"]["isosurfaces"] = "light_pass";
  std::ofstream(dir.file("isosurface.json")) << isosurface.dump();
  for (const std::string scene : {"shell", "deep", "deep_shared", "classic", "surfaces", "sat", "isosurface"}) {
    SCOPED_TRACE(scene);
    const std::string scene_file = quote(dir.file(scene + ".json"));
    const CliRun whole = penumbra_cli("render " + scene_file + " -o " + quote(dir.file(scene + "_whole.pfm")));
    ASSERT_EQ(whole.status, 0) << whole.err;
    const Image reference = read_image(dir.file(scene + "_whole.pfm"));
    ASSERT_TRUE(non_trivial(reference));
    for (const int np : rank_counts({1, 2, 3, 4})) {
      SCOPED_TRACE(np);
      const std::string n = std::to_string(np);
      const std::string out = dir.file(scene + "_np" + n + ".pfm"), loop = dir.file(scene + "_loop" + n + ".pfm");
      const CliRun ranks = mpirun_cli(np, "render " + scene_file + " -o " + quote(out) + " --stats " + quote(dir.file("stats" + n + ".json")));
      ASSERT_EQ(ranks.status, 0) << ranks.out << ranks.err;
      EXPECT_NE(ranks.err.find(n + " ranks"), std::string::npos) << ranks.err;
      const CliRun brick_loop = penumbra_cli("render " + scene_file + " --slabs " + n + " -o " + quote(loop));
      ASSERT_EQ(brick_loop.status, 0) << brick_loop.err;
      const Image distributed = read_image(out);
      FailureImages keep;
      keep.add(scene + "_np" + n, distributed, read_image(loop));
      if (scene.starts_with("deep") || scene == "sat") {
        // the deep shadow map's products multiply, the SAT's sums add, in another order across ranks
        EXPECT_GT(compare_images(distributed, read_image(loop)).psnr, 100.0);
      } else {
        EXPECT_EQ(distributed.pixels(), read_image(loop).pixels());
      }
      if (np == 1) {
        EXPECT_EQ(distributed.pixels(), reference.pixels());
      }
      const ImageDifference d = compare_images(distributed, reference);
      EXPECT_LE(d.max_abs, 1.0 - kEarlyTermination + 1e-4);
      EXPECT_GT(d.psnr, 50.0);

      // --stats: one entry per rank; the CSSM, the classic map and the deep shadow map are combined
      // across ranks
      const nlohmann::json stats = nlohmann::json::parse(slurp(dir.file("stats" + n + ".json")));
      ASSERT_EQ(stats["ranks"].size(), static_cast<std::size_t>(np));
      std::size_t held = 0, fewest = 10;
      for (const auto& r : stats["ranks"]) {
        EXPECT_EQ(r["shadow_bytes_sent"].get<double>() > 0, np > 1) << r.dump();
        EXPECT_EQ(r["image_bytes_sent"].get<double>() > 0, np > 1) << r.dump();
        EXPECT_GE(r["render_ms"].get<double>(), 0.0);
        if (r.contains("spheres")) held += r["spheres"].get<std::size_t>(), fewest = std::min(fewest, r["spheres"].get<std::size_t>());
      }
      if (scene == "surfaces") {  // each rank holds the spheres reaching into its slab: all ten, some twice
        EXPECT_GE(held, 10u);
        EXPECT_EQ(fewest < 10, np > 1);
      }
    }
  }
}

// Each rank reads only its brick (distributed/brick_reading.h) of a volume file, given in a scene file or
// opened directly: NRRD raw data and raw files by seeking, NRRD gzip data by decompressing up to the
// brick's last slice. The ranks then find the value range and (without a transfer function) the
// histogram of the whole grid, so the frame is still the brick loop's, which reads the whole file, bit
// for bit. A file opened directly under ray-traced shadows is read whole by every rank, which says why.
// Broken on purpose (a file opened directly given the transfer function chosen from each rank's own
// brick rather than from the summed histogram) it fails at 53–73 dB.
TEST(MpiRender, RanksReadOnlyTheirBrickAndGiveTheSameFrame) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun not installed (scripts/install-deps.sh installs Open MPI)";
  ScratchDir dir;
  // the shell's voxels in files: 32 slices of 32 x 32 floats
  const Volume shell = make_procedural_volume({{"name", "hollow-sphere"}, {"size", 32}});
  ASSERT_EQ(shell.type(), ScalarType::Float32);
  std::vector<float> voxels(shell.voxel_count());
  for (std::size_t i = 0; i < voxels.size(); ++i) voxels[i] = shell.value(i) + 0.01f * static_cast<float>(i % 7);  // not two-valued
  const Vec3 s = shell.spacing(), o = shell.origin();
  const std::string header = "type: float\ndimension: 3\nsizes: 32 32 32\nendian: little\nspacings: " + std::to_string(s.x) + " " +
                             std::to_string(s.y) + " " + std::to_string(s.z) + "\n";
  write_file(dir.file("raw.nrrd"), nrrd_file(header + "encoding: raw\n", to_bytes(voxels)));
  write_file(dir.file("gzip.nrrd"), nrrd_file(header + "encoding: gzip\n", gzip(to_bytes(voxels))));
  write_file(dir.file("shell.raw"), to_bytes(voxels));
  {  // the same voxels as an OME-Zarr pyramid of 8³ chunks: a rank reads the chunks of its slices' rows
    Volume copy(ScalarType::Float32, {32, 32, 32}, s, o);
    std::memcpy(copy.data(), voxels.data(), voxels.size() * sizeof(float));
    copy.recompute_range();
    OmeZarrWriteOptions zarr;
    zarr.chunk = 8;
    write_ome_zarr(copy, dir.file("shell.zarr"), zarr);
  }
  std::uint64_t zarr_bytes = 0;  // level 0's chunk files
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir.file("shell.zarr") + "/0"))
    if (e.is_regular_file() && e.path().filename().string()[0] != '.') zarr_bytes += e.file_size();
  const auto scene_of = [&](const nlohmann::json& volume, bool with_tf) {
    nlohmann::json j = shell_scene();
    nlohmann::json v = volume;
    v["origin"] = {o.x, o.y, o.z};
    if (with_tf) v["transfer_function"] = j["volumes"][0]["transfer_function"];
    j["volumes"] = nlohmann::json::array({v});
    return j;
  };
  const std::uint64_t file_bytes = voxels.size() * sizeof(float);
  std::ofstream(dir.file("raw.json")) << scene_of({{"file", dir.file("raw.nrrd")}}, true).dump();
  std::ofstream(dir.file("gzip.json")) << scene_of({{"file", dir.file("gzip.nrrd")}}, true).dump();
  std::ofstream(dir.file("plain.json")) << scene_of({{"file", dir.file("shell.raw")},
                                                     {"raw", {{"dims", {32, 32, 32}}, {"type", "float32"}, {"spacing", {s.x, s.y, s.z}}}}},
                                                    true).dump();
  std::ofstream(dir.file("chosen.json")) << scene_of({{"file", dir.file("raw.nrrd")}}, false).dump();  // transfer function from the data
  std::ofstream(dir.file("zarr.json")) << scene_of({{"file", dir.file("shell.zarr")}, {"level", 0}}, true).dump();
  nlohmann::json sat = scene_of({{"file", dir.file("raw.nrrd")}}, true);  // the SAT summed over the bricks
  sat["shadows"] = {{"technique", "sat_cone"}};
  sat["ambient"] = {{"technique", "sat_shells"}};
  sat["light_cache"] = {{"resolution", 32}};
  std::ofstream(dir.file("sat.json")) << sat.dump();
  // spheres inside the volume, whose particle AO composes the volume's opacity per cell: each rank
  // composes the cells its slab owns, the ranks add them
  nlohmann::json implants = scene_of({{"file", dir.file("raw.nrrd")}}, true);
  implants["particles"] = nlohmann::json::array(
      {{{"procedural", {{"name", "random-spheres"}, {"count", 30}, {"radius", 0.06}, {"seed", 7}}}}});
  implants["ambient"] = {{"technique", "particle_ao"}, {"grid", 24}};
  std::ofstream(dir.file("implants.json")) << implants.dump();
  // an isosurface of the hidden volume before a wall, and one inside the visible volume: each rank
  // extracts it from its brick's cells; the light pass's fit, holes and depths combine over the ranks
  nlohmann::json isosurface = scene_of({{"file", dir.file("raw.nrrd")}}, true);
  isosurface["volumes"][0]["visible"] = false;
  isosurface["planes"] = nlohmann::json::array({{{"point", {-0.7, 0, 0}}, {"normal", {1, 0, 0}}, {"size", 3}}});
  isosurface["isosurfaces"] = nlohmann::json::array({{{"volume", 0}, {"value", 0.5}}});
  // lit from +x and +z: the shell's shadow falls on the wall lower in z than the shell's points that
  // cast it, so wall points in the lower slabs are shadowed by cells of the upper ones
  isosurface["lights"] = nlohmann::json::array({{{"type", "directional"}, {"direction", {-1.0, 0.0, -1.0}}}});
  isosurface["shadows"]["isosurfaces"] = "light_pass";
  std::ofstream(dir.file("isosurface.json")) << isosurface.dump();
  // without the wall, under a point light: the light's frustum is fitted to the shell's visible points
  // only, so each rank passes those of its slab that no other rank's surface hides
  nlohmann::json lamp = isosurface;
  lamp.erase("planes");
  lamp["lights"] = nlohmann::json::array({{{"type", "point"}, {"position", {0.9, -0.3, 1.1}}}});
  std::ofstream(dir.file("isosurface_lamp.json")) << lamp.dump();
  isosurface["volumes"][0]["visible"] = true;
  isosurface["isosurfaces"][0]["value"] = 0.95;
  std::ofstream(dir.file("isosurface_in_volume.json")) << isosurface.dump();
  // the files opened directly (a scene of their own, scene_io/data_scene.h: its transfer function chosen
  // from the ranks' summed histogram, its floor and camera from the whole grid's box)
  const std::string raw_layout = " --raw-dims 32 32 32 --raw-type float32 --raw-spacing " + std::to_string(s.x) + " " +
                                 std::to_string(s.y) + " " + std::to_string(s.z);
  const std::vector<std::pair<std::string, std::string>> direct{
      {"direct_nrrd", quote(dir.file("raw.nrrd"))},
      {"direct_gzip", quote(dir.file("gzip.nrrd"))},
      {"direct_zarr", quote(dir.file("shell.zarr")) + " --level 0"},
      {"direct_raw", quote(dir.file("shell.raw")) + raw_layout},
      {"direct_traced", quote(dir.file("raw.nrrd")) + " --set shadows.technique=ray_traced"}};  // every rank reads it whole
  std::vector<std::pair<std::string, std::string>> scenes;
  for (const std::string scene : {"raw", "gzip", "zarr", "plain", "chosen", "sat", "implants", "isosurface", "isosurface_lamp", "isosurface_in_volume"})
    scenes.emplace_back(scene, quote(dir.file(scene + ".json")));
  scenes.insert(scenes.end(), direct.begin(), direct.end());
  for (const auto& [scene, scene_file] : scenes) {
    SCOPED_TRACE(scene);
    for (const int np : rank_counts({2, 3})) {
      SCOPED_TRACE(np);
      const std::string n = std::to_string(np);
      const std::string out = dir.file(scene + "_np" + n + ".pfm"), loop = dir.file(scene + "_loop" + n + ".pfm");
      const std::string stats_file = dir.file(scene + "_stats" + n + ".json");
      const CliRun ranks = mpirun_cli(np, "render " + scene_file + " -o " + quote(out) + " --stats " + quote(stats_file));
      ASSERT_EQ(ranks.status, 0) << ranks.out << ranks.err;
      const CliRun brick_loop = penumbra_cli("render " + scene_file + " --slabs " + n + " -o " + quote(loop));
      ASSERT_EQ(brick_loop.status, 0) << brick_loop.err;
      FailureImages keep;
      keep.add(scene + "_np" + n, read_image(out), read_image(loop));
      if (scene == "sat") {
        EXPECT_GT(compare_images(read_image(out), read_image(loop)).psnr, 100.0);  // sums in another order
      } else if (scene.starts_with("isosurface")) {
        // a brick's cells lie at its own origin's multiples of the spacing, the whole grid's at the
        // grid's: the points move by rounding, and the extraction's order by pixel may pick another
        // cell's point where two are equally near
        const ImageDifference d = compare_images(read_image(out), read_image(loop));
        EXPECT_GT(d.psnr, 50.0) << d.max_abs;
        std::printf("%s on %d ranks against the brick loop: %.1f dB, max %.4f\n", scene.c_str(), np, d.psnr, d.max_abs);
      } else {
        EXPECT_TRUE(read_image(out).pixels() == read_image(loop).pixels()) << compare_images(read_image(out), read_image(loop)).psnr << " dB";
      }
      ASSERT_TRUE(non_trivial(read_image(out)));

      const nlohmann::json stats = nlohmann::json::parse(slurp(stats_file));
      EXPECT_EQ(stats["whole_slices"], 32);
      if (scene == "direct_traced") {
        EXPECT_FALSE(stats["bricks_read"].get<bool>()) << stats.dump();
        EXPECT_NE(stats["read_whole_because"].get<std::string>().find("ray_traced"), std::string::npos) << stats.dump();
        EXPECT_NE(ranks.err.find("note: every rank read the whole volume: the ray_traced shadows"), std::string::npos) << ranks.err;
        continue;
      }
      EXPECT_TRUE(stats["bricks_read"].get<bool>()) << stats.dump();
      int next = 0;  // the bricks cover the grid in order, each with up to two ghost slices a side
      for (const auto& r : stats["ranks"]) {
        const int first = r["slices"][0].get<int>(), end = r["slices"][1].get<int>();
        EXPECT_LE(first, next);
        EXPECT_GE(first, next - 2 * kGhostSlices);
        EXPECT_LT(end - first, 32) << r.dump();
        next = end;
        EXPECT_EQ(r["volume_bytes"].get<std::uint64_t>(), static_cast<std::uint64_t>(end - first) * 32 * 32 * sizeof(float));
        if (scene.ends_with("zarr")) {  // compressed chunks: fewer bytes than the whole level's
          EXPECT_LT(r["bytes_read"].get<std::uint64_t>(), zarr_bytes);
        } else if (scene != "gzip" && scene != "direct_gzip") {
          EXPECT_EQ(r["bytes_read"].get<std::uint64_t>(), r["volume_bytes"].get<std::uint64_t>());
        }
        EXPECT_LT(r["bytes_read"].get<std::uint64_t>(), file_bytes);
      }
      EXPECT_EQ(next, 32);
    }
  }
}

// Sequences under mpirun. --frames: every frame of a volume series, each rank reading only its brick of
// the step (bytes read per frame), is the brick loop's frame of that step bit for bit; every frame of a
// trajectory, the ranks splitting the spheres of the frame, is the single-process sequence's frame.
// --orbit and --light-orbit: one rank gives the single-process sequence bit for bit, three ranks within
// the slabs' early-termination bound. A range past the last frame stops every rank with the message
// naming it.
TEST(MpiRender, RanksRenderSequencesFrameByFrame) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun not installed (scripts/install-deps.sh installs Open MPI)";
  ScratchDir dir;
  // three steps of the shell, moved along x by a voxel a step
  const Volume shell = make_procedural_volume({{"name", "hollow-sphere"}, {"size", 32}});
  const Vec3 s = shell.spacing(), o = shell.origin();
  const std::string header = "type: float\ndimension: 3\nsizes: 32 32 32\nendian: little\nencoding: raw\nspacings: " +
                             std::to_string(s.x) + " " + std::to_string(s.y) + " " + std::to_string(s.z) + "\n";
  for (int k = 0; k < 3; ++k) {
    std::vector<float> voxels(shell.voxel_count());
    for (std::size_t i = 0; i < voxels.size(); ++i) voxels[i] = i % 32 >= static_cast<std::size_t>(k) ? shell.value(i - static_cast<std::size_t>(k)) : 0.0f;
    write_file(dir.file("step_" + std::to_string(k) + ".nrrd"), nrrd_file(header, to_bytes(voxels)));
  }
  nlohmann::json series = shell_scene();
  series["volumes"][0].erase("procedural");
  series["volumes"][0]["files"] = dir.file("step_%d.nrrd");
  series["volumes"][0]["origin"] = {o.x, o.y, o.z};
  std::ofstream(dir.file("series.json")) << series.dump();
  // a trajectory: a ring of atoms and one flying over it, over a floor, under the ISSM
  {
    std::ofstream topology(dir.file("top.xyz")), trajectory(dir.file("traj.xyz"));
    for (int k = 0; k < 3; ++k)
      for (std::ofstream* out : {&trajectory, &topology}) {
        if (out == &topology && k > 0) continue;
        *out << "13\nframe " << k << "\n";
        for (int i = 0; i < 12; ++i) *out << "C " << 4 * std::cos(0.5236 * i) << " " << 4 * std::sin(0.5236 * i) << " 0\n";
        *out << "O " << -5 + 2.5 * k << " 0.5 4\n";
      }
  }
  nlohmann::json trajectory;
  trajectory["particles"] = nlohmann::json::array({{{"file", dir.file("top.xyz")}, {"trajectory", dir.file("traj.xyz")}}});
  trajectory["planes"] = nlohmann::json::array({{{"point", {0, 0, -2}}, {"normal", {0, 0, 1}}, {"size", 30}}});
  trajectory["lights"] = nlohmann::json::array({{{"type", "directional"}, {"direction", {0.2, 0.3, -1.0}}}});
  trajectory["shadows"] = {{"technique", "issm"}, {"resolution", 256}};
  trajectory["camera"] = {{"eye", {0, -14, 16}}, {"target", {0, 0, 0}}, {"up", {0, 0, 1}}, {"width", 64}, {"height", 48}};
  std::ofstream(dir.file("trajectory.json")) << trajectory.dump();

  for (const std::string scene : {"series", "trajectory"}) {
    SCOPED_TRACE(scene);
    const std::string scene_file = quote(dir.file(scene + ".json"));
    const CliRun whole = penumbra_cli("render " + scene_file + " --frames 0:2 -o " + quote(dir.file(scene + "_whole.pfm")));
    ASSERT_EQ(whole.status, 0) << whole.err;
    for (const int np : rank_counts({2, 3})) {
      SCOPED_TRACE(np);
      const std::string n = std::to_string(np), out = dir.file(scene + "_np" + n + ".pfm"), stats = dir.file(scene + "_stats" + n + ".json");
      const CliRun ranks = mpirun_cli(np, "render " + scene_file + " --frames 0:2 -o " + quote(out) + " --stats " + quote(stats));
      ASSERT_EQ(ranks.status, 0) << ranks.out << ranks.err;
      const nlohmann::json frames = nlohmann::json::parse(slurp(stats))["frames"];
      ASSERT_EQ(frames.size(), 3u);
      Image previous;
      for (int k = 0; k < 3; ++k) {
        SCOPED_TRACE(k);
        const std::string suffix = "_00" + std::to_string(k) + ".pfm";
        const Image distributed = read_image(dir.file(scene + "_np" + n + suffix));
        EXPECT_EQ(frames[k]["time"], k);
        ASSERT_EQ(frames[k]["ranks"].size(), static_cast<std::size_t>(np));
        Image reference = read_image(dir.file(scene + "_whole" + suffix));
        if (scene == "series") {  // the brick loop of step k; each rank read its slices of step k's file only
          const std::string loop = dir.file("loop" + n + "_" + std::to_string(k) + ".pfm");
          const CliRun brick_loop = penumbra_cli("render " + scene_file + " --set time=" + std::to_string(k) + " --slabs " + n + " -o " + quote(loop));
          ASSERT_EQ(brick_loop.status, 0) << brick_loop.err;
          EXPECT_GT(compare_images(distributed, reference).psnr, 50.0);
          reference = read_image(loop);
          for (const auto& r : frames[k]["ranks"]) {
            const auto slices = r["slices"].get<std::vector<int>>();
            EXPECT_EQ(r["bytes_read"].get<std::uint64_t>(), static_cast<std::uint64_t>(slices[1] - slices[0]) * 32 * 32 * 4) << r.dump();
            EXPECT_LT(slices[1] - slices[0], 32);
          }
        }
        FailureImages keep;
        keep.add(scene + "_np" + n + "_frame" + std::to_string(k), distributed, reference);
        EXPECT_TRUE(distributed.pixels() == reference.pixels()) << "psnr " << compare_images(distributed, reference).psnr;
        if (k > 0) {
          EXPECT_GT(compare_images(distributed, previous).max_abs, 0.05);  // the data moved
        }
        previous = distributed;
      }
    }
  }
  std::ofstream(dir.file("shell.json")) << shell_scene().dump();
  for (const std::string orbit : {"orbit", "light-orbit"}) {
    SCOPED_TRACE(orbit);
    const std::string args = "render " + quote(dir.file("shell.json")) + " --" + orbit + " 3 -o ";
    const CliRun whole = penumbra_cli(args + quote(dir.file(orbit + "_whole.pfm")));
    ASSERT_EQ(whole.status, 0) << whole.err;
    for (const int np : rank_counts({1, 3})) {
      SCOPED_TRACE(np);
      const std::string out = dir.file(orbit + "_np" + std::to_string(np) + ".pfm"), stats = dir.file(orbit + "_stats.json");
      const CliRun ranks = mpirun_cli(np, args + quote(out) + " --stats " + quote(stats));
      ASSERT_EQ(ranks.status, 0) << ranks.out << ranks.err;
      const nlohmann::json frames = nlohmann::json::parse(slurp(stats))["frames"];
      ASSERT_EQ(frames.size(), 3u);
      Image previous;
      for (int k = 0; k < 3; ++k) {
        SCOPED_TRACE(k);
        // each rank keeps its renderer: after the first frame an orbit rebuilds nothing, a light orbit
        // that light's shadows only (reduced across the ranks again)
        const std::vector<std::string> kept_all = {}, light_only = {"lights.0.shadows"};
        const auto rebuilt = frames[k]["rebuilt"].get<std::vector<std::string>>();
        if (k > 0) {
          EXPECT_EQ(rebuilt, orbit == "orbit" ? kept_all : light_only);
        }
        for (std::size_t r = 0; r < static_cast<std::size_t>(np); ++r) {
          const nlohmann::json& rank = frames[k]["ranks"][r];
          EXPECT_EQ(rank["structures_rebuilt"].get<std::size_t>(), rebuilt.size()) << rank.dump();
          // a frame's bytes are its own (not the sequence's so far): its reductions, its image, a few
          // bytes of agreement; a kept shadow map is not reduced again, a rebuilt one as in frame 0
          const double shadow = rank["shadow_bytes_sent"], image = rank["image_bytes_sent"], first_shadow = frames[0]["ranks"][r]["shadow_bytes_sent"];
          EXPECT_LT(rank["bytes_sent"].get<double>() - shadow - image, 256.0) << rank.dump();
          if (k > 0 && np > 1) {
            EXPECT_EQ(shadow, orbit == "orbit" ? 0.0 : first_shadow) << rank.dump();
          }
        }
        const std::string suffix = "_00" + std::to_string(k) + ".pfm";
        const Image distributed = read_image(dir.file(orbit + "_np" + std::to_string(np) + suffix));
        const Image reference = read_image(dir.file(orbit + "_whole" + suffix));
        FailureImages keep;
        keep.add(orbit + "_np" + std::to_string(np) + "_frame" + std::to_string(k), distributed, reference);
        if (np == 1) {
          EXPECT_TRUE(distributed.pixels() == reference.pixels()) << "psnr " << compare_images(distributed, reference).psnr;
        } else {
          EXPECT_GT(compare_images(distributed, reference).psnr, 50.0);
        }
        if (k > 0) {
          EXPECT_GT(compare_images(distributed, previous).max_abs, 0.05);  // the camera or the light turned
        }
        previous = distributed;
      }
    }
  }
  // an orbit turns the scene every rank holds: its brick is read for the first frame only
  const CliRun turn = mpirun_cli(2, "render " + quote(dir.file("series.json")) + " --orbit 2 -o " + quote(dir.file("turn.png")) +
                                        " --stats " + quote(dir.file("turn.json")));
  ASSERT_EQ(turn.status, 0) << turn.err;
  const nlohmann::json turned = nlohmann::json::parse(slurp(dir.file("turn.json")))["frames"];
  ASSERT_EQ(turned.size(), 2u);
  for (int r = 0; r < 2; ++r) {
    EXPECT_GT(turned[0]["ranks"][r]["bytes_read"].get<std::uint64_t>(), 0u);
    EXPECT_EQ(turned[1]["ranks"][r]["bytes_read"].get<std::uint64_t>(), 0u);
  }
  const CliRun past = mpirun_cli(2, "render " + quote(dir.file("series.json")) + " --frames 1:3 -o " + quote(dir.file("past.png")));
  EXPECT_NE(past.status, 0);
  EXPECT_EQ(count(past.err, "--frames 1:3: frame 3 is past the last frame (3 frames, 0 to 2)"), 2u) << past.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("past_000.png")));
}

// IceT as the compositor (distributed/icet_compositor.h): radix-k and binary swap give direct send's
// frame on 3 and 4 ranks. Blended slabs: IceT's over operator in its own tree order, so up to float
// rounding (above 100 dB, max 1e-5), with the eye between the slabs too (rays going up and down from
// it, one order for the frame). Split spheres by depth: the nearest surface, bit for bit (the depths
// scaled by a power of two). Broken on purpose: the slabs composited in rank order rather than from the
// eye's slab outwards gives 36.7–38.6 dB on the middle-eye view (the others pass: their eye is below
// every slab); the depth scale 4 times too large (depths beyond IceT's far plane) 9.3 dB on the spheres.
TEST(MpiRender, IceTCompositesTheFrameOfDirectSend) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun not installed (scripts/install-deps.sh installs Open MPI)";
  if (!icet_built()) GTEST_SKIP() << "built without IceT (scripts/fetch-icet.sh)";
  ScratchDir dir;
  std::ofstream(dir.file("shell.json")) << shell_scene().dump();
  nlohmann::json inside = shell_scene();  // the eye at the shell's mid height, looking across and down
  inside["camera"] = {{"width", 64}, {"height", 56}, {"eye", {1.5, 0.6, 0.1}}, {"target", {0.0, 0.0, -0.3}}, {"fov_deg", 70}};
  std::ofstream(dir.file("inside.json")) << inside.dump();
  nlohmann::json surfaces = shell_scene();
  surfaces["planes"] = nlohmann::json::array({{{"point", {-0.7, 0, 0}}, {"normal", {1, 0, 0}}, {"size", 3}}});
  surfaces["particles"] = nlohmann::json::array(
      {{{"procedural", {{"name", "random-spheres"}, {"count", 10}, {"radius", 0.08}, {"seed", 5}}}, {"origin", {0.0, 0.1, 0.2}}}});
  std::ofstream(dir.file("surfaces.json")) << surfaces.dump();
  std::ofstream(dir.file("spheres.json")) << spheres_scene().dump();
  for (const std::string scene : {"shell", "inside", "surfaces", "spheres"}) {
    SCOPED_TRACE(scene);
    const std::string scene_file = quote(dir.file(scene + ".json"));
    // 3 ranks (binary swap folds the third in) and 4 for the eye between slabs and the spheres
    for (const int np : rank_counts(scene == "inside" || scene == "spheres" ? std::vector<int>{3, 4} : std::vector<int>{3})) {
      SCOPED_TRACE(np);
      const std::string n = std::to_string(np);
      const std::string direct = dir.file(scene + "_direct" + n + ".pfm");
      const CliRun by_direct_send = mpirun_cli(np, "render " + scene_file + " -o " + quote(direct));
      ASSERT_EQ(by_direct_send.status, 0) << by_direct_send.err;
      const Image reference = read_image(direct);
      ASSERT_TRUE(non_trivial(reference));
      for (const std::string compositor : {"icet", "icet-bswap"}) {
        SCOPED_TRACE(compositor);
        const std::string out = dir.file(scene + "_" + compositor + n + ".pfm"), stats = dir.file("stats.json");
        const CliRun ranks = mpirun_cli(np, "render " + scene_file + " --compositor " + compositor + " -o " + quote(out) + " --stats " + quote(stats));
        ASSERT_EQ(ranks.status, 0) << ranks.out << ranks.err;
        EXPECT_NE(ranks.err.find("composited by " + compositor + ","), std::string::npos) << ranks.err;
        const Image composited = read_image(out);
        FailureImages keep;
        keep.add(scene + "_" + compositor + n, composited, reference);
        const ImageDifference d = compare_images(composited, reference);
        if (scene == "spheres") {
          EXPECT_EQ(composited.pixels(), reference.pixels()) << "psnr " << d.psnr << ", max " << d.max_abs;
        } else {
          EXPECT_GT(d.psnr, 100.0);
          EXPECT_LT(d.max_abs, 1e-5);
        }
        const nlohmann::json s = nlohmann::json::parse(slurp(stats));
        EXPECT_TRUE(s["compositing"].get<std::string>().starts_with(compositor + ",")) << s["compositing"];
        for (const auto& r : s["ranks"]) EXPECT_GE(r["composite_ms"].get<double>(), 0.0);
        EXPECT_GT(s["ranks"][1]["image_bytes_sent"].get<double>(), 0.0) << s["ranks"].dump();  // IceT's ICET_BYTES_SENT
      }
    }
  }
  // one process composites nothing
  const CliRun alone = penumbra_cli("render " + quote(dir.file("shell.json")) + " --compositor icet -o " + quote(dir.file("alone.png")));
  EXPECT_NE(alone.status, 0);
  EXPECT_NE(alone.err.find("--compositor icet: it composites the ranks of mpirun"), std::string::npos) << alone.err;
}

// More ranks than voxel slices, a scene with what is not split yet, a file that one rank cannot read
// (an MPMD launch: rank 1 is given another scene), a command that does not run distributed: every rank
// exits non-zero with the same message, and nothing is written.
TEST(MpiRender, BadLaunchesStopEveryRankWithTheSameMessage) {
  if (!have_mpirun()) GTEST_SKIP() << "mpirun not installed (scripts/install-deps.sh installs Open MPI)";
  ScratchDir dir;
  std::ofstream(dir.file("thin.json")) << volume_scene({{"name", "sphere"}, {"size", 3}}, constant_tf(0.2, 1, 1, 1)).dump();
  nlohmann::json spheres = spheres_scene();
  spheres["particles"] = nlohmann::json::array({{{"procedural", {{"name", "random-spheres"}, {"count", 3}, {"radius", 0.1}, {"seed", 2}}}}});
  std::ofstream(dir.file("spheres.json")) << spheres.dump();
  spheres["shadows"] = {{"technique", "ray_traced"}};
  std::ofstream(dir.file("traced.json")) << spheres.dump();
  nlohmann::json plane = spheres_scene();
  plane.erase("particles");
  plane.erase("shadows");
  std::ofstream(dir.file("plane.json")) << plane.dump();
  nlohmann::json missing = shell_scene();
  missing["volumes"][0].erase("procedural");
  missing["volumes"][0]["file"] = dir.file("not-there.nrrd");
  std::ofstream(dir.file("missing.json")) << missing.dump();
  std::ofstream(dir.file("shell.json")) << shell_scene().dump();

  struct Case {
    int np;
    std::string args, needle;
  };
  const std::string out = " -o " + quote(dir.file("out.png"));
  const std::vector<Case> cases{
      {4, "render " + quote(dir.file("thin.json")) + out, "4 slabs for a volume of 3 voxel slices"},
      {4, "render " + quote(dir.file("spheres.json")) + out, "4 ranks for 3 spheres"},
      {2, "render " + quote(dir.file("traced.json")) + out, "spheres split over MPI ranks cast shadows by issm or cssm"},
      {2, "render " + quote(dir.file("plane.json")) + out, "must hold a volume"},
      {3, "render " + quote(dir.file("missing.json")) + out, "not-there.nrrd"},
      {2, "render " + quote(dir.file("shell.json")) + out + " --accumulate 4", "one frame or a sequence"},
      {2, "render " + quote(dir.file("shell.json")) + out + " --slabs 2", "the ranks are the slabs"},
      {2, "render " + quote(dir.file("shell.json")) + out + " --compositor over", "--compositor over: expected direct-send, icet"},
      {2, "info " + quote(dir.file("shell.json")), "only `penumbra render` runs"},
      {3, "render " + quote(dir.file("shell.json")) + " --bogus" + out, "--bogus"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.args);
    const CliRun r = mpirun_cli(c.np, c.args);
    EXPECT_NE(r.status, 0);
    EXPECT_NE(r.status, 124) << "timed out: a rank hung";
    EXPECT_EQ(count(r.err, "penumbra: error: rank "), static_cast<std::size_t>(c.np)) << r.err;
    EXPECT_EQ(count(r.err, c.needle), static_cast<std::size_t>(c.np)) << r.err;
  }
  // MPMD: the same scene on two "nodes" (working folders), the volume file only on the first: rank 1
  // cannot read it
  for (const char* node : {"node_a", "node_b"}) {
    std::filesystem::create_directory(dir.file(node));
    nlohmann::json j = shell_scene();
    j["volumes"][0].erase("procedural");
    j["volumes"][0]["file"] = "local.nrrd";  // beside the scene, on each node
    std::ofstream(dir.file(std::string(node) + "/scene.json")) << j.dump();
  }
  write_file(dir.file("node_a/local.nrrd"), nrrd_file("type: uchar\ndimension: 3\nsizes: 8 8 8\nencoding: raw\n", Bytes(512, 100)));
  const CliRun mpmd = penumbra_cli_with_launcher(
      "timeout 300 mpirun --oversubscribe --bind-to none -x ASAN_OPTIONS=detect_leaks=0 -np 1 -wdir " + quote(dir.file("node_a")) + " " +
          quote(PENUMBRA_CLI) + " render scene.json" + out + " : -np 1 -wdir " + quote(dir.file("node_b")) + " ",
      "render scene.json" + out);
  EXPECT_NE(mpmd.status, 0);
  EXPECT_NE(mpmd.status, 124) << "timed out: a rank hung";
  EXPECT_EQ(count(mpmd.err, "penumbra: error: rank 1 of 2: "), 2u) << mpmd.err;
  EXPECT_EQ(count(mpmd.err, "local.nrrd"), 2u) << mpmd.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("out.png")));
  // MPMD: two valid but different scenes (their ranks would call different collectives)
  const CliRun different = penumbra_cli_with_launcher(
      "timeout 300 mpirun --oversubscribe --bind-to none -x ASAN_OPTIONS=detect_leaks=0 -np 1 " + quote(PENUMBRA_CLI) + " render " +
          quote(dir.file("shell.json")) + out + " : -np 1 ",
      "render " + quote(dir.file("thin.json")) + out);
  EXPECT_NE(different.status, 0);
  EXPECT_NE(different.status, 124) << "timed out: a rank hung";
  EXPECT_EQ(count(different.err, "penumbra: error: rank 1 of 2 opened another scene than rank 0"), 2u) << different.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("out.png")));
}
