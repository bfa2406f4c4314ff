// What ships with penumbra: every scene file in scenes/ loads and renders, test-sized (shrunk with
// --set overrides, as a user would), the image stored beside this test in tests/reference/shipped/, and `penumbra demo --quick` writes
// the files it says it writes, each a valid, non-trivial PNG, and prints the table it promises.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "cli_run.h"
#include "penumbra/core/image_io.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene_io/scene_file.h"
#include "image_check.h"
#include "test_scenes.h"

using namespace penumbra;
using namespace penumbra::test;
namespace fs = std::filesystem;

namespace {

// The checkout: PENUMBRA_SHARED_DATA_DIR is "<checkout>/../shared/data".
fs::path source_dir() {
  std::string d = PENUMBRA_SHARED_DATA_DIR;
  const std::string tail = "/../shared/data";
  if (d.size() > tail.size() && d.compare(d.size() - tail.size(), tail.size(), tail) == 0) d.resize(d.size() - tail.size());
  return fs::path(d);
}

bool shared_data_present() { return fs::exists(fs::path(PENUMBRA_SHARED_DATA_DIR) / "cranium_ct.nrrd"); }

// Share of pixels that differ from `background` by more than 0.02 in some channel.
double covered(const Image& img, const Rgb& background) {
  std::size_t n = 0;
  for (const Rgb& p : img.pixels())
    n += std::max({std::abs(p.r - background.r), std::abs(p.g - background.g), std::abs(p.b - background.b)}) > 0.02f;
  return static_cast<double>(n) / static_cast<double>(img.pixels().size());
}

// --set overrides that make a scene file test-sized: a 64×48 image, 64² shadow maps, small light and
// ambient caches, procedural volumes of ≤ 32 voxels a side (ct-body: 64 × 64 × 216), only where the
// scene file sets the key (so that no override names a key its technique does not read).
std::vector<std::string> shrink(const nlohmann::json& j) {
  std::vector<std::string> sets{"camera.width=64", "camera.height=48"};
  if (j.contains("shadows") && j["shadows"].contains("resolution")) sets.push_back("shadows.resolution=64");
  if (j.contains("light_cache") && j["light_cache"].contains("resolution")) sets.push_back("light_cache.resolution=32");
  if (j.contains("ambient") && j["ambient"].value("technique", "") == "particle_ao") sets.push_back("ambient.grid=16");
  if (j.contains("volumes"))
    for (std::size_t i = 0; i < j["volumes"].size(); ++i) {
      const auto& v = j["volumes"][i];
      if (!v.contains("procedural")) continue;
      const std::string p = "volumes." + std::to_string(i) + ".procedural.";
      if (v["procedural"].contains("size")) sets.push_back(p + "size=32");
      if (v["procedural"].contains("dims")) sets.push_back(p + "dims=[64,64,216]");
    }
  return sets;
}

std::vector<std::string> scene_files() {
  std::vector<std::string> names;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(source_dir() / "scenes", ec))
    if (e.path().extension() == ".json") names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  return names;
}

TEST(ShippedScenes, TheScenesDirectoryHoldsTheSceneFiles) { EXPECT_GE(scene_files().size(), 10u) << source_dir() / "scenes"; }

// Every scenes/*.json loads (its data files from ../shared/data) and renders, test-sized, the image stored
// in tests/reference/shipped/NAME.png (8-bit sRGB, as written; the rendered image is compared after the
// same 8-bit encoding). Every technique of the shipped scenes is deterministic: the stochastic ones
// (cssm, the jitter, the AO directions) draw position-keyed random numbers from fixed seeds, and one or
// two threads give the same bytes (test_engine, test_mixed_scenes). So the image equals its reference
// exactly where the compiler computes as it did when the reference was written; the 50 dB floor admits
// a few 8-bit steps in a few pixels (another compiler's rounding, a sanitizer build) and nothing a
// technique that changed would produce: a shadow technique that returns no shadows, or AO that returns
// none, moves a shipped scene's image to 20-40 dB. The image must also show something: at least 5 % of
// the pixels differ from the background, and not all in one colour.
// PENUMBRA_UPDATE_REFERENCES=1 writes the references anew (look at them before committing them).
// Scenes whose data file is missing are skipped, not failed (CI has ../shared/data). The two virus
// capsid assemblies (1m4x: 16 M spheres, 325 MB, ~9 s; 3j6r: 1 M) are skipped under the sanitizer.
constexpr double kShippedPsnrFloor = 50;

// The image as an 8-bit PNG holds it (the references are PNGs).
Image as_png(const Image& img, const std::string& name) {
  const fs::path path = fs::temp_directory_path() / ("penumbra-shipped-" + name + "-" + std::to_string(::getpid()) + ".png");
  write_image(path.string(), img);
  Image back = read_image(path.string());
  fs::remove(path);
  return back;
}

class ShippedScene : public ::testing::TestWithParam<std::string> {};

TEST_P(ShippedScene, LoadsAndRenders) {
  const fs::path file = source_dir() / "scenes" / GetParam();
  const nlohmann::json j = read_json_file(file.string());
  if (!shared_data_present() && j.dump().find("shared/data") != std::string::npos) GTEST_SKIP() << "../shared/data is missing";
  if (sanitize_scale() && (GetParam() == "1m4x.json" || GetParam() == "3j6r.json")) GTEST_SKIP() << "too big for the sanitizer run";
  const Scene scene = load_scene(file.string(), shrink(j));
  EXPECT_EQ(scene.camera.width, 64);
  EXPECT_EQ(scene.camera.height, 48);
  const Image img = as_png(Renderer(scene).render().image, file.stem().string());
  ASSERT_EQ(img.width(), 64);
  ASSERT_EQ(img.height(), 48);
  const fs::path reference_file = source_dir() / "tests" / "reference" / "shipped" / (file.stem().string() + ".png");
  if (const char* update = std::getenv("PENUMBRA_UPDATE_REFERENCES"); update != nullptr && std::string(update) == "1") {
    fs::create_directories(reference_file.parent_path());
    write_image(reference_file.string(), img);
  }
  ASSERT_TRUE(fs::exists(reference_file)) << reference_file << " is missing: render it with PENUMBRA_UPDATE_REFERENCES=1 and look at it";
  const Image reference = read_image(reference_file.string());
  FailureImages keep;
  keep.add(file.stem().string(), img, reference);
  const ImageDifference d = compare_images(img, reference);
  EXPECT_GT(d.psnr, kShippedPsnrFloor) << GetParam() << " differs from " << reference_file << " (RMSE " << d.rmse << ", max " << d.max_abs << ")";
  const double share = covered(img, scene.background);
  std::printf("[ scene    ] %-18s %5.1f %% of the pixels show something, %.1f dB from the reference\n", GetParam().c_str(), 100 * share, d.psnr);
  EXPECT_GT(share, 0.05) << "blank: the image shows (almost) only the background";
  EXPECT_TRUE(non_trivial(img)) << "all one colour";
}

INSTANTIATE_TEST_SUITE_P(Files, ShippedScene, ::testing::ValuesIn(scene_files()), [](const ::testing::TestParamInfo<std::string>& scene) {
  std::string name = scene.param.substr(0, scene.param.size() - 5);  // without ".json"
  for (char& c : name)
    if (!std::isalnum(static_cast<unsigned char>(c))) c = '_';
  return name;
});
GTEST_ALLOW_UNINSTANTIATED_PARAMETERIZED_TEST(ShippedScene);

// ---------------------------------------------------------------------------------------------------
// penumbra demo --quick

// `penumbra demo --quick -o DIR` (test-sized scenes), once with a data directory that holds nothing, so
// that the CT and molecule scenes are skipped (and it says so), once with ../shared/data. It prints, for each scene, a table with one
// row per technique and a line "wrote DIR/NAME_*.png and NAME_comparison.png (a | b | c | d)"; the
// files it writes are NAME_<technique>.png for every row and NAME_comparison.png, the four named images
// side by side 4 pixels apart. Checked: exit 0; the "wrote" lines name DIR; exactly the expected files
// exist, each a PNG that reads back with the scene's size (the comparison: four of them and three gaps),
// and shows something; a technique's image differs from another's; the ray-traced rows compare equal to
// themselves (PSNR inf) and the `none` row does not.
using DemoFiles = std::map<std::string, std::vector<std::string>>;  // scene → its per-technique suffixes

// Runs `penumbra demo --quick` with `data_dir` and checks what it wrote against `expected`.
void check_demo(const std::string& data_dir, const DemoFiles& expected, bool data_scenes) {
  ScratchDir dir;
  const fs::path out = dir.path() / "demo";
  const CliRun r = penumbra_cli("demo --quick --threads 2 --data-dir " + quote(data_dir) + " -o " + quote(out.string()));
  ASSERT_EQ(r.status, 0) << r.out << r.err;
  EXPECT_EQ(r.out.find("cranium_ct.nrrd not found") == std::string::npos, data_scenes) << r.out;
  EXPECT_EQ(r.out.find("1aon.pdb.gz not found") == std::string::npos, data_scenes) << r.out;
  std::set<std::string> want;
  for (const auto& [scene, parts] : expected) {
    const std::string wrote = "wrote " + out.string() + "/" + scene + "_*.png and " + scene + "_comparison.png";
    EXPECT_NE(r.out.find(wrote), std::string::npos) << "no line \"" << wrote << "\" in\n" << r.out;
    for (const auto& p : parts) want.insert(scene + "_" + p + ".png");
    want.insert(scene + "_comparison.png");
  }
  if (data_scenes) want.insert("ct-implants.xyz");  // the demo's implants, beside its images
  std::set<std::string> have;
  for (const auto& e : fs::directory_iterator(out)) have.insert(e.path().filename().string());
  EXPECT_EQ(have, want);
  FailureImages keep;
  for (const auto& [scene, parts] : expected) {
    SCOPED_TRACE(scene);
    std::vector<Image> images;
    for (const auto& p : parts) {
      const std::string file = (out / (scene + "_" + p + ".png")).string();
      if (!fs::exists(file)) continue;
      images.push_back(read_image(file));  // throws on an invalid PNG
      keep.add(scene + "_" + p, images.back(), Image{});
      EXPECT_TRUE(non_trivial(images.back())) << file;
      EXPECT_GT(covered(images.back(), images.back().at(0, 0)), 0.05) << file << " is (almost) blank";
    }
    ASSERT_EQ(images.size(), parts.size());
    for (const Image& img : images) {
      EXPECT_EQ(img.width(), images[0].width());
      EXPECT_EQ(img.height(), images[0].height());
    }
    EXPECT_LE(images[0].width(), 128) << "--quick renders small images";
    const Image comparison = read_image((out / (scene + "_comparison.png")).string());
    EXPECT_EQ(comparison.width(), 4 * images[0].width() + 3 * 4);
    EXPECT_EQ(comparison.height(), images[0].height());
    // the first technique (no shadows / local lighting / points) is not the reference's picture
    EXPECT_GT(compare_images(images.front(), images.back()).max_abs, 0.05) << "the techniques' images differ";
  }
  // The volume tables: the ray_traced row is the reference (RMSE 0, PSNR inf); `none` is not.
  const std::regex row(R"(\|\s*(none|ray_traced)\s*\|[^\n]*\|\s*([0-9.]+)\s*\|\s*(inf|[0-9.]+)\s*\|)");
  std::map<std::string, std::string> psnr;
  for (std::sregex_iterator it(r.out.begin(), r.out.end(), row), end; it != end; ++it) psnr.emplace((*it)[1], (*it)[3]);
  EXPECT_EQ(psnr["ray_traced"], "inf") << r.out;
  ASSERT_TRUE(psnr.count("none")) << r.out;
  EXPECT_NE(psnr["none"], "inf") << r.out;
}

const DemoFiles kProceduralDemo{{"test-spheres", {"none", "shadow_map", "deep_shadow_map", "cssm", "ray_traced"}},
                                {"spheres-floor", {"ll", "issm", "issm_ao", "ray_traced", "ray_traced_ao"}},
                                {"ct-body", {"points", "light_pass", "mesh", "ray_traced"}}};

TEST(Demo, QuickModeWritesTheImagesItNames) {
  ScratchDir empty;
  check_demo(empty.path().string(), kProceduralDemo, false);
}

// The same with the data sets: the head CT (volume techniques), 1AON (sphere techniques) and the two
// mixed scenes join.
TEST(Demo, QuickModeWithTheDataSetsWritesTheirImagesToo) {
  if (!shared_data_present() || !fs::exists(fs::path(PENUMBRA_SHARED_DATA_DIR) / "1aon.pdb.gz")) GTEST_SKIP() << "no ../shared/data";
  DemoFiles all = kProceduralDemo;
  all["cranium"] = all["test-spheres"];
  all["1aon"] = all["spheres-floor"];
  all["ct-implants"] = all["test-spheres"];    // the mixed scenes: every map technique and ray_traced
  all["groel-density"] = all["test-spheres"];
  check_demo(PENUMBRA_SHARED_DATA_DIR, all, true);
}

}  // namespace
