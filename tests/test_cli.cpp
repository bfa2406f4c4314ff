// The command line end to end (DESIGN.md "The command-line contract", docs/cli.md): runs the built
// `penumbra` binary (PENUMBRA_CLI) on small procedural scenes written to a scratch directory, and checks
// images, --stats JSON, sequences, error messages and that failures leave no output behind.
#include <gtest/gtest.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>

#include "cli_run.h"
#include "penumbra/core/image_io.h"
#include "test_scenes.h"

using namespace penumbra;
using namespace penumbra::test;
namespace fs = std::filesystem;

namespace {

std::set<std::string> listing(const fs::path& dir) {
  std::set<std::string> names;
  for (const auto& e : fs::directory_iterator(dir)) names.insert(e.path().filename().string());
  return names;
}

// A small scene: test-spheres 32³ over a floor, a point light, 32² image, 64² maps.
nlohmann::json cli_scene() {
  return nlohmann::json::parse(R"({
    "volumes": [ { "procedural": { "name": "test-spheres", "size": 32 }, "transfer_function": { "preset": "test-spheres" } } ],
    "planes": [ { "point": [0, -0.52, 0], "normal": [0, 1, 0], "color": [0.9, 0.9, 0.9], "size": 4 } ],
    "lights": [ { "type": "point", "position": [0.7, 1.6, 0.9] } ],
    "camera": { "width": 32, "height": 32 },
    "shadows": { "technique": "deep_shadow_map", "resolution": 64, "seed": 3 }
  })");
}

std::string write_scene(const ScratchDir& dir, const std::string& name, const nlohmann::json& j) {
  const std::string path = dir.file(name);
  std::ofstream(path) << j.dump(2);
  return path;
}

bool contains(const std::string& haystack, const std::string& needle) { return haystack.find(needle) != std::string::npos; }

}  // namespace

TEST(Cli, RenderWritesImageAndStats) {
  ScratchDir dir;
  const std::string scene = write_scene(dir, "scene.json", cli_scene());
  const CliRun r = penumbra_cli("render " + quote(scene) + " -o " + quote(dir.file("out.png")) + " --width 40 --height 24 --stats " +
                             quote(dir.file("stats.json")) + " --threads 1");
  ASSERT_EQ(r.status, 0) << r.err;
  const Image img = read_image(dir.file("out.png"));
  EXPECT_EQ(img.width(), 40);
  EXPECT_EQ(img.height(), 24);
  const nlohmann::json s = nlohmann::json::parse(slurp(dir.file("stats.json")));
  EXPECT_EQ(s.at("technique"), "deep_shadow_map");
  EXPECT_EQ(s.at("width"), 40);
  EXPECT_EQ(s.at("height"), 24);
  for (const char* k : {"build", "render", "total"}) {
    ASSERT_TRUE(s.at("timings_ms").at(k).is_number()) << k;
    EXPECT_GE(s["timings_ms"][k].get<double>(), 0.0) << k;
  }
  EXPECT_GE(s["timings_ms"]["total"].get<double>(), s["timings_ms"]["render"].get<double>());
  // 3 nodes x 3 channels x (depth, T) floats + 3 count bytes + 1 surface depth float per texel
  EXPECT_EQ(s.at("memory_bytes").at("shadow"), 64 * 64 * (3 * 3 * 2 * 4 + 3 + 4));
  EXPECT_EQ(s.at("memory_bytes").at("ambient"), 0);
  EXPECT_EQ(s.at("counts").at("voxels"), 32 * 32 * 32);
  EXPECT_EQ(s.at("threads"), 1);
  EXPECT_EQ(s.at("seed"), 3);
  EXPECT_FALSE(s.contains("frames")) << "a single frame has no frames list";
  EXPECT_EQ(listing(dir.path()), (std::set<std::string>{"scene.json", "out.png", "stats.json"})) << "no temporary files left";
}

TEST(Cli, SetOverridesTheScene) {
  ScratchDir dir;
  const std::string scene = write_scene(dir, "scene.json", cli_scene());
  const CliRun r = penumbra_cli("render " + quote(scene) + " -o " + quote(dir.file("out.pfm")) +
                             " --set shadows.technique=cssm --set shadows.resolution=32 --set 'lights.0.intensity=0.5'" +
                             " --stats " + quote(dir.file("stats.json")));
  ASSERT_EQ(r.status, 0) << r.err;
  const nlohmann::json s = nlohmann::json::parse(slurp(dir.file("stats.json")));
  EXPECT_EQ(s.at("technique"), "cssm");
  EXPECT_EQ(s.at("memory_bytes").at("shadow"), 32 * 32 * 3 * 4) << "CSSM: resolution² · 3 floats";
  const Image img = read_image(dir.file("out.pfm"));
  EXPECT_EQ(img.width(), 32);
}

TEST(Cli, OrbitWritesNumberedFramesAndReusesShadows) {
  ScratchDir dir;
  const std::string scene = write_scene(dir, "scene.json", cli_scene());
  const CliRun r = penumbra_cli("render " + quote(scene) + " -o " + quote(dir.file("name.png")) + " --orbit 3 --stats " +
                             quote(dir.file("stats.json")));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(listing(dir.path()), (std::set<std::string>{"scene.json", "stats.json", "name_000.png", "name_001.png", "name_002.png"}));
  const nlohmann::json s = nlohmann::json::parse(slurp(dir.file("stats.json")));
  ASSERT_TRUE(s.at("frames").is_array());
  ASSERT_EQ(s["frames"].size(), 3u);
  const auto first = s["frames"][0].at("rebuilt").get<std::vector<std::string>>();
  EXPECT_NE(std::find(first.begin(), first.end(), "lights.0.shadows"), first.end());
  EXPECT_EQ(s["frames"][1].at("rebuilt"), nlohmann::json::array());
  EXPECT_EQ(s["frames"][2].at("rebuilt"), nlohmann::json::array());
  for (const auto& f : s["frames"]) EXPECT_TRUE(f.at("timings_ms").at("render").is_number());
  // The camera moved by a third of a turn between frames: every point at distance ρ from the vertical
  // axis through the target moves by 2ρ·sin 60° ≈ 1.7ρ; the test-spheres' balls (radius ≈ 0.1–0.2, up to
  // 0.35 from the axis) and the floor's square edges land on other pixels, so a large share of the
  // pixels that show something must change: at least half of the non-background pixels of the two
  // frames by more than 2/255 (measured 97 %), and the frames' PSNR under 22 dB (measured 17.1; one
  // pixel of 1024 differing fully would give 30 dB). One differing bit, or an unmoved camera, fails.
  const Image a = read_image(dir.file("name_000.png")), b = read_image(dir.file("name_001.png"));
  const Rgb background = a.at(0, 0);
  std::size_t shown = 0, changed = 0;
  for (std::size_t i = 0; i < a.pixels().size(); ++i) {
    const Rgb p = a.pixels()[i], q = b.pixels()[i];
    auto differs = [](const Rgb& x, const Rgb& y) {
      return std::max({std::abs(x.r - y.r), std::abs(x.g - y.g), std::abs(x.b - y.b)}) > 2.0f / 255.0f;
    };
    shown += differs(p, background) || differs(q, background);
    changed += differs(p, q);
  }
  std::printf("[ orbit    ] %zu of %zu shown pixels changed, PSNR %.2f dB\n", changed, shown, compare_images(a, b).psnr);
  EXPECT_GT(shown, a.pixels().size() / 4) << "the frames show the scene";
  EXPECT_GE(static_cast<double>(changed), 0.5 * static_cast<double>(shown)) << changed << " of " << shown << " pixels changed";
  EXPECT_LT(compare_images(a, b).psnr, 22.0);
}

TEST(Cli, LightOrbitRebuildsShadowsEveryFrame) {
  ScratchDir dir;
  const std::string scene = write_scene(dir, "scene.json", cli_scene());
  const CliRun r = penumbra_cli("render " + quote(scene) + " -o " + quote(dir.file("light.png")) + " --light-orbit 3 --stats " +
                             quote(dir.file("stats.json")));
  ASSERT_EQ(r.status, 0) << r.err;
  for (const char* f : {"light_000.png", "light_001.png", "light_002.png"}) EXPECT_TRUE(fs::exists(dir.file(f))) << f;
  const nlohmann::json s = nlohmann::json::parse(slurp(dir.file("stats.json")));
  ASSERT_EQ(s.at("frames").size(), 3u);
  for (std::size_t i = 1; i < s["frames"].size(); ++i) EXPECT_EQ(s["frames"][i].at("rebuilt"), nlohmann::json::array({"lights.0.shadows"}));
}

// Bad inputs: non-zero exit, a message naming the key or file, and nothing written (no image, no stats,
// no .partial file).
TEST(Cli, BadInputsFailWithAMessageAndLeaveNoOutput) {
  ScratchDir dir;
  const std::string scene = write_scene(dir, "scene.json", cli_scene());
  nlohmann::json missing = cli_scene();
  missing["volumes"][0].erase("procedural");
  missing["volumes"][0]["file"] = "missing_volume.nrrd";
  const std::string missing_scene = write_scene(dir, "missing.json", missing);
  const std::string broken = dir.file("broken.json");
  std::ofstream(broken) << "{ \"camera\": { \"width\": 16, } ";
  const std::string out = " -o " + quote(dir.file("out.png")) + " --stats " + quote(dir.file("stats.json"));
  struct Case { std::string args, needle; };
  const std::vector<Case> cases{
      {"render " + quote(scene) + out + " --set shadows.bogus=1", "shadows.bogus"},
      {"render " + quote(scene) + out + " --set lights.3.intensity=1", "lights.3"},
      {"render " + quote(scene) + out + " --set shadows.technique=issm", "is for spheres"},
      {"render " + quote(scene) + out + " --set shadows.cone_angle=95", "shadows.cone_angle"},
      {"render " + quote(missing_scene) + out, "missing_volume.nrrd"},
      {"render " + quote(scene) + " -o " + quote(dir.file("out.jpg")) + " --stats " + quote(dir.file("stats.json")), ".jpg"},
      {"render " + quote(broken) + out, "broken.json"},
      {"render " + quote(dir.file("nonexistent.json")) + out, "nonexistent.json"},
      {"render " + quote(scene) + " -o " + quote(dir.file("no_such_dir/out.png")), "no_such_dir"},
  };
  const auto before = listing(dir.path());
  for (const Case& c : cases) {
    SCOPED_TRACE(c.args);
    const CliRun r = penumbra_cli(c.args);
    EXPECT_NE(r.status, 0);
    EXPECT_TRUE(contains(r.err, c.needle)) << "stderr: " << r.err;
    EXPECT_LT(r.status, 128) << "crashed";
    EXPECT_EQ(listing(dir.path()), before) << "output left behind";
  }
}

// An unwritable --stats path must fail before any frame is written (no output behind a failed command).
TEST(Cli, UnwritableStatsPathFailsBeforeWritingAnything) {
  ScratchDir dir;
  const std::string scene = write_scene(dir, "scene.json", cli_scene());
  const auto before = listing(dir.path());
  const CliRun r = penumbra_cli("render " + quote(scene) + " -o " + quote(dir.file("out.png")) + " --stats " +
                                quote(dir.file("no_such_dir/stats.json")));
  EXPECT_NE(r.status, 0);
  EXPECT_TRUE(contains(r.err, "no_such_dir")) << r.err;
  EXPECT_EQ(listing(dir.path()), before) << "a failed render left its image behind";
}

// Image headers that promise more pixels than their file holds are refused before the pixels are
// allocated (65536² RGB floats would be 51 GB), with a message naming the file; and an output with the
// wrong extension leaves the file already there untouched (the extension is checked before anything is
// written, the bytes go through a temporary file).
TEST(Cli, LyingImageHeadersAndBadOutputNamesFailCleanly) {
  ScratchDir dir;
  const std::string scene = write_scene(dir, "scene.json", cli_scene());
  ASSERT_EQ(penumbra_cli("render " + quote(scene) + " -o " + quote(dir.file("a.png"))).status, 0);
  std::ofstream(dir.file("huge.pfm"), std::ios::binary) << "PF\n65536 65536\n-1\n";
  // a PNG signature, an IHDR of 65536 x 65536 RGB at 8 bits and the start of its image data (two bytes)
  const auto be32 = [](unsigned v) { return std::string{char(v >> 24), char((v >> 16) & 0xff), char((v >> 8) & 0xff), char(v & 0xff)}; };
  const auto chunk = [&](const std::string& type_and_data) {
    const auto crc = static_cast<unsigned>(::crc32(0, reinterpret_cast<const Bytef*>(type_and_data.data()), static_cast<uInt>(type_and_data.size())));
    return be32(static_cast<unsigned>(type_and_data.size() - 4)) + type_and_data + be32(crc);
  };
  std::ofstream(dir.file("huge.png"), std::ios::binary) << std::string("\x89PNG\r\n\x1a\n", 8)
                                                        << chunk("IHDR" + be32(65536) + be32(65536) + std::string{8, 2, 0, 0, 0})
                                                        << chunk("IDAT\x78\x9c");
  for (const char* huge : {"huge.pfm", "huge.png"}) {
    SCOPED_TRACE(huge);
    const CliRun r = penumbra_cli("compare " + quote(dir.file(huge)) + " " + quote(dir.file("a.png")));
    EXPECT_EQ(r.status, 1) << r.err;
    EXPECT_TRUE(contains(r.err, huge) && contains(r.err, "65536x65536")) << r.err;
  }
  // a trajectory's positions to a file that is neither .npy nor .txt: refused, the file left as it was
  std::ofstream(dir.file("run.xyz")) << "2\nframe 0\nC 0 0 0\nO 1 1 1\n2\nframe 1\nC 0 0 1\nO 1 1 2\n";
  std::ofstream(dir.file("notes.csv")) << "my notes\n";
  const CliRun positions = penumbra_cli("info " + quote(dir.file("run.xyz")) + " --trajectory --positions " + quote(dir.file("notes.csv")));
  EXPECT_EQ(positions.status, 1) << positions.err;
  EXPECT_TRUE(contains(positions.err, "must end in .npy or .txt")) << positions.err;
  EXPECT_EQ(slurp(dir.file("notes.csv")), "my notes\n");
  ASSERT_EQ(penumbra_cli("info " + quote(dir.file("run.xyz")) + " --trajectory --frame 1 --positions " + quote(dir.file("p.txt"))).status, 0);
  EXPECT_EQ(slurp(dir.file("p.txt")), "0 0 1\n1 1 2\n");
  EXPECT_EQ(listing(dir.path()), (std::set<std::string>{"scene.json", "a.png", "huge.pfm", "huge.png", "run.xyz", "notes.csv", "p.txt"}));
}

TEST(Cli, CompareReportsPsnrAndWritesDiff) {
  ScratchDir dir;
  const std::string scene = write_scene(dir, "scene.json", cli_scene());
  ASSERT_EQ(penumbra_cli("render " + quote(scene) + " -o " + quote(dir.file("a.png"))).status, 0);
  ASSERT_EQ(penumbra_cli("render " + quote(scene) + " -o " + quote(dir.file("b.png")) + " --set shadows.technique=none").status, 0);
  CliRun same = penumbra_cli("compare " + quote(dir.file("a.png")) + " " + quote(dir.file("a.png")));
  ASSERT_EQ(same.status, 0) << same.err;
  EXPECT_TRUE(contains(same.out, "psnr inf")) << same.out;
  EXPECT_TRUE(contains(same.out, "rmse 0.000000")) << same.out;
  CliRun diff = penumbra_cli("compare " + quote(dir.file("a.png")) + " " + quote(dir.file("b.png")) + " --diff " + quote(dir.file("d.png")));
  ASSERT_EQ(diff.status, 0) << diff.err;
  const auto at = diff.out.find("psnr ");
  ASSERT_NE(at, std::string::npos) << diff.out;
  const double psnr = std::strtod(diff.out.c_str() + at + 5, nullptr);
  EXPECT_TRUE(std::isfinite(psnr)) << diff.out;
  EXPECT_GT(psnr, 10.0);
  const Image d = read_image(dir.file("d.png"));
  EXPECT_EQ(d.width(), 32);
  // Images of different sizes cannot be compared: an error, not a crash.
  ASSERT_EQ(penumbra_cli("render " + quote(scene) + " -o " + quote(dir.file("c.png")) + " --width 16").status, 0);
  const CliRun bad = penumbra_cli("compare " + quote(dir.file("a.png")) + " " + quote(dir.file("c.png")));
  EXPECT_NE(bad.status, 0);
  EXPECT_LT(bad.status, 128);
}

TEST(Cli, InfoDescribesAVolumeFile) {
  const char* env = std::getenv("PENUMBRA_DATA_DIR");
  const std::string file = (env && *env ? std::string(env) : std::string(PENUMBRA_SHARED_DATA_DIR)) + "/neghip.nhdr";
  if (!fs::exists(file)) GTEST_SKIP() << file << " not found";
  const CliRun r = penumbra_cli("info " + quote(file));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "66 x 66 x 66")) << r.out;
  const CliRun missing = penumbra_cli("info " + quote("/nonexistent/volume.nhdr"));
  EXPECT_NE(missing.status, 0);
  EXPECT_TRUE(contains(missing.err, "/nonexistent/volume.nhdr")) << missing.err;
}

TEST(Cli, InfoDescribesAParticleFile) {
  const char* env = std::getenv("PENUMBRA_DATA_DIR");
  const std::string file = (env && *env ? std::string(env) : std::string(PENUMBRA_SHARED_DATA_DIR)) + "/1tii.pdb";
  if (!fs::exists(file)) GTEST_SKIP() << file << " not found";
  const CliRun r = penumbra_cli("info " + quote(file));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.out, "spheres     5684")) << r.out;
  const CliRun no_assembly = penumbra_cli("info " + quote(file) + " --assembly 3");
  EXPECT_NE(no_assembly.status, 0);
  EXPECT_TRUE(contains(no_assembly.err, "assembly 3")) << no_assembly.err;
}

// A key the chosen technique does not read gets one line on stderr naming it and its readers; with
// --strict it is an error: exit 1 and no image (issue 12 §3: cssm used to take pcf silently).
TEST(Cli, KeysTheTechniqueDoesNotReadAreReportedAndRefusedWithStrict) {
  ScratchDir dir;
  const std::string scene = write_scene(dir, "scene.json", cli_scene());
  const std::string base = "render " + quote(scene) + " --set shadows.technique=cssm --set shadows.pcf=5";
  const CliRun noted = penumbra_cli(base + " -o " + quote(dir.file("noted.png")));
  ASSERT_EQ(noted.status, 0) << noted.err;
  EXPECT_TRUE(contains(noted.err, "shadows.pcf is not read by cssm")) << noted.err;
  EXPECT_TRUE(contains(noted.err, "read by: shadow_map")) << noted.err;
  EXPECT_FALSE(contains(noted.err, "shadows.seed")) << "cssm reads seed: " << noted.err;
  const CliRun strict = penumbra_cli(base + " --strict -o " + quote(dir.file("strict.png")));
  EXPECT_EQ(strict.status, 1);
  EXPECT_TRUE(contains(strict.err, "shadows.pcf")) << strict.err;
  EXPECT_FALSE(fs::exists(dir.file("strict.png")));
  // Every key read: --strict renders, and says nothing about keys.
  const CliRun clean = penumbra_cli("render " + quote(scene) + " --set shadows.technique=cssm --strict -o " + quote(dir.file("clean.png")));
  ASSERT_EQ(clean.status, 0) << clean.err;
  EXPECT_FALSE(contains(clean.err, "is not read")) << clean.err;
  EXPECT_TRUE(fs::exists(dir.file("clean.png")));
}

// --edits replays a session: the last image, and per step the paths, what the preview rebuilt (with
// the edit as cause) and what the full frame refined, and the two times.
TEST(Cli, EditsReplayASessionIntoStats) {
  ScratchDir dir;
  const std::string scene = write_scene(dir, "scene.json", cli_scene());
  const std::string edits = dir.file("edits.json");
  std::ofstream(edits) << R"([
    {"set": {"camera.direction": [0.3, 0.5, 1.0]}},
    {"set": {"lights.0.position": [-0.7, 1.6, 0.9], "shading.ambient": 0.3}, "idle_ms": 30},
    {"set": {"volumes.0.transfer_function.opacity_scale": 2}, "cancel_after_ms": 0}
  ])";
  const CliRun r = penumbra_cli("render " + quote(scene) + " -o " + quote(dir.file("last.png")) + " --edits " + quote(edits) +
                                " --stats " + quote(dir.file("stats.json")));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_EQ(read_image(dir.file("last.png")).width(), 32);
  const nlohmann::json s = nlohmann::json::parse(slurp(dir.file("stats.json")));
  const auto& steps = s.at("edits");
  ASSERT_EQ(steps.size(), 3u);
  EXPECT_EQ(steps[0].at("paths"), nlohmann::json::array({"camera.direction"}));
  EXPECT_TRUE(steps[0].at("rebuilt").empty());
  EXPECT_EQ(steps[1].at("paths"), nlohmann::json::array({"lights.0.position", "shading.ambient"}));
  EXPECT_EQ(steps[1].at("rebuilt"), nlohmann::json::parse(R"([{"structure": "lights.0.shadows", "cause": "lights.0.position"}])"));
  EXPECT_EQ(steps[1].at("refined"), nlohmann::json::parse(R"([{"structure": "lights.0.shadows", "cause": "refine"}])"));
  EXPECT_GE(steps[1].at("samples").get<int>(), 1);
  for (const auto& e : steps) {
    EXPECT_GT(e.at("preview_ms").get<double>(), 0);
    EXPECT_GE(e.at("full_ms").get<double>(), e.at("preview_ms").get<double>());
  }
  EXPECT_TRUE(steps[2].contains("cancel"));
}

// A bad step names the file, the step and the path; nothing is written.
TEST(Cli, BadEditsFailWithAMessageAndLeaveNoOutput) {
  ScratchDir dir;
  const std::string scene = write_scene(dir, "scene.json", cli_scene());
  auto run = [&](const std::string& text) {
    const std::string edits = dir.file("edits.json");
    std::ofstream(edits) << text;
    return penumbra_cli("render " + quote(scene) + " -o " + quote(dir.file("out.png")) + " --edits " + quote(edits) + " --stats " +
                        quote(dir.file("stats.json")));
  };
  const std::pair<const char*, const char*> cases[] = {
      {R"({"set": {}})", "expected a JSON list of steps"},
      {R"([{"set": {"camera.fov_deg": 40}}, {"set": {"lights.0.nonsense": 1}}])", "step 1"},
      {R"([{"set": {"isosurfaces.0.value": 1}}])", "isosurfaces"},
      {R"([{"set": {"camera.fov_deg": "wide"}}])", "camera.fov_deg"},
      {R"([{"set": {"camera.fov_deg": 40}, "idle": 5}])", "unknown key 'idle'"},
      {R"([{"idle_ms": 5}])", "no 'set'"},
      {R"([{"set": {"camera.fov_deg": 40}, "idle_ms": -1}])", "idle_ms"},
  };
  for (const auto& [text, expect] : cases) {
    const CliRun r = run(text);
    EXPECT_NE(r.status, 0) << text;
    EXPECT_TRUE(contains(r.err, expect)) << text << "\n" << r.err;
    EXPECT_TRUE(contains(r.err, "edits.json")) << r.err;
    EXPECT_FALSE(fs::exists(dir.file("out.png"))) << text;
    EXPECT_FALSE(fs::exists(dir.file("stats.json"))) << text;
  }
}
