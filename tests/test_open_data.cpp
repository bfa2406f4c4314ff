// Data files opened directly (scene_io/data_scene.h, data/transfer_function_choice.h): `penumbra render
// FILE...` makes a scene from volumes and molecules, `--write-scene` saves it so that rendering the saved
// file gives the same image, and a volume without a transfer function gets one chosen from its data.
#include <gtest/gtest.h>

#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "cli_run.h"
#include "penumbra/core/error.h"
#include "penumbra/core/image_io.h"
#include "penumbra/data/transfer_function_choice.h"
#include "penumbra/engine/engine.h"
#include "penumbra/scene_io/data_scene.h"
#include "image_check.h"
#include "shared_data.h"
#include "test_scenes.h"

using namespace penumbra;
using namespace penumbra::test;
namespace fs = std::filesystem;

namespace {

std::string data(const std::string& name) { return quote(shared_data_dir() + "/" + name); }
bool contains(const std::string& haystack, const std::string& needle) { return haystack.find(needle) != std::string::npos; }

void expect_same_pixels(const std::string& a, const std::string& b) {
  const Image x = read_image(a), y = read_image(b);
  ASSERT_EQ(x.width(), y.width());
  ASSERT_EQ(x.height(), y.height());
  EXPECT_EQ(x.pixels(), y.pixels()) << a << " and " << b << " differ";
}

}  // namespace

TEST(OpenData, AVolumeFileRendersAndItsSavedSceneRendersTheSameImage) {
  SKIP_WITHOUT_SHARED_DATA("neghip.nhdr");
  ScratchDir dir;
  const CliRun first = penumbra_cli("render " + data("neghip.nhdr") + " -o " + quote(dir.file("direct.pfm")) + " --width 48 --height 40 --write-scene " +
                                    quote(dir.file("neghip.json")));
  ASSERT_EQ(first.status, 0) << first.err;
  EXPECT_TRUE(contains(first.err, "cssm (volumes"));
  const nlohmann::json saved = nlohmann::json::parse(slurp(dir.file("neghip.json")));
  ASSERT_TRUE(saved["volumes"][0].contains("transfer_function"));
  EXPECT_TRUE(saved["volumes"][0]["transfer_function"].contains("points"));  // uint8: chosen from the histogram
  EXPECT_FALSE(fs::path(saved["volumes"][0]["file"].get<std::string>()).is_absolute());
  ASSERT_EQ(saved["planes"].size(), 1u);
  const CliRun again = penumbra_cli("render " + quote(dir.file("neghip.json")) + " -o " + quote(dir.file("saved.pfm")));
  ASSERT_EQ(again.status, 0) << again.err;
  expect_same_pixels(dir.file("direct.pfm"), dir.file("saved.pfm"));
  EXPECT_TRUE(non_trivial(read_image(dir.file("direct.pfm"))));
}

// A volume in a patient frame (NIfTI, DICOM: LPS, superior along +z) stands up, seen from the front
// (-y, anterior); a volume without one keeps y up.
TEST(OpenData, AVolumeInAPatientFrameStandsUpSeenFromTheFront) {
  SKIP_WITHOUT_SHARED_DATA("chris_t1.nii.gz");
  SKIP_WITHOUT_SHARED_DATA("neghip.nhdr");
  ScratchDir dir;
  for (const auto& [file, up] : {std::pair{"chris_t1.nii.gz", nlohmann::json{0, 0, 1}}, std::pair{"neghip.nhdr", nlohmann::json{0, 1, 0}}}) {
    SCOPED_TRACE(file);
    const CliRun r = penumbra_cli("render " + data(file) + " -o " + quote(dir.file("x.png")) + " --width 16 --height 16 --write-scene " +
                                  quote(dir.file("x.json")));
    ASSERT_EQ(r.status, 0) << r.err;
    const nlohmann::json saved = nlohmann::json::parse(slurp(dir.file("x.json")));
    EXPECT_EQ(saved["planes"][0]["normal"], up) << "the floor lies under the data";
    if (up[2] == 1) {
      EXPECT_EQ(saved["camera"]["up"], up);
      EXPECT_LT(saved["camera"]["direction"][1].get<double>(), 0.0) << "seen from anterior";
    }
  }
}

TEST(OpenData, AVolumeAndAMoleculeMakeOneMixedScene) {
  SKIP_WITHOUT_SHARED_DATA("neghip.nhdr");
  SKIP_WITHOUT_SHARED_DATA("1tii.pdb");
  ScratchDir dir;
  const CliRun r = penumbra_cli("render " + data("neghip.nhdr") + " " + data("1tii.pdb") + " -o " + quote(dir.file("mixed.png")) +
                                " --width 40 --height 32 --set shadows.resolution=128 --write-scene " + quote(dir.file("mixed.json")));
  ASSERT_EQ(r.status, 0) << r.err;
  EXPECT_TRUE(contains(r.err, "cssm (volumes")) << r.err;
  EXPECT_TRUE(contains(r.err, "issm (spheres)")) << r.err;
  const nlohmann::json saved = nlohmann::json::parse(slurp(dir.file("mixed.json")));
  EXPECT_EQ(saved["volumes"].size(), 1u);
  EXPECT_EQ(saved["particles"].size(), 1u);
  EXPECT_EQ(saved["shadows"]["resolution"], 128);  // the --set is part of the saved scene
  EXPECT_EQ(saved["ambient"]["technique"], "particle_ao");
}

TEST(OpenData, ARawVolumeWithItsLayoutEqualsItsNrrdHeader) {
  SKIP_WITHOUT_SHARED_DATA("headsq.raw");
  SKIP_WITHOUT_SHARED_DATA("headsq.nhdr");
  ScratchDir dir;
  const CliRun raw = penumbra_cli("render " + data("headsq.raw") + " --raw-dims 64 64 93 --raw-type int16 --raw-spacing 3.2 3.2 1.5 -o " +
                                  quote(dir.file("raw.pfm")) + " --width 32 --height 32 --set shadows.resolution=64");
  ASSERT_EQ(raw.status, 0) << raw.err;
  const CliRun nrrd = penumbra_cli("render " + data("headsq.nhdr") + " -o " + quote(dir.file("nrrd.pfm")) + " --width 32 --height 32 --set shadows.resolution=64");
  ASSERT_EQ(nrrd.status, 0) << nrrd.err;
  expect_same_pixels(dir.file("raw.pfm"), dir.file("nrrd.pfm"));
}

TEST(OpenData, BadInputsNameTheFileOrOptionAndLeaveNoOutput) {
  SKIP_WITHOUT_SHARED_DATA("headsq.raw");
  SKIP_WITHOUT_SHARED_DATA("neghip.nhdr");
  SKIP_WITHOUT_SHARED_DATA("1tii.pdb");
  ScratchDir dir;
  const std::string text = dir.file("notes.txt");
  std::ofstream(text) << "not data\n";
  const std::string scene = dir.file("scene.json");
  std::ofstream(scene) << "{}";
  const std::string out = " -o " + quote(dir.file("out.png")) + " --write-scene " + quote(dir.file("saved.json"));
  struct Case { std::string args, needle; };
  const std::vector<Case> cases{
      {"render " + quote(text) + out, "notes.txt: unknown kind of file"},
      {"render " + data("headsq.raw") + out, "--raw-dims"},
      {"render " + data("neghip.nhdr") + " --raw-dims 4 4 4 --raw-type uint8" + out, "no .raw file"},
      {"render " + data("headsq.raw") + " --raw-dims 64 64 93" + out, "--raw-type"},
      {"render " + data("headsq.raw") + " --raw-dims 64 64 93 --raw-type int17" + out, "int17"},
      {"render " + data("headsq.raw") + " --raw-dims 64 64 90 --raw-type int16" + out, "headsq.raw"},
      {"render " + quote(scene) + " " + data("1tii.pdb") + out, "on its own"},
      {"render " + data("neghip.nhdr") + " -o " + quote(dir.file("out.png")) + " --write-scene " + quote(dir.file("saved.txt")), ".json"},
      {"render " + data("neghip.nhdr") + " --set volumes.0.bogus=1" + out, "volumes.0.bogus"},
  };
  const auto before = std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator{});
  for (const Case& c : cases) {
    SCOPED_TRACE(c.args);
    const CliRun r = penumbra_cli(c.args);
    EXPECT_NE(r.status, 0);
    EXPECT_LT(r.status, 128) << "crashed";
    EXPECT_TRUE(contains(r.err, c.needle)) << "stderr: " << r.err;
    EXPECT_EQ(std::distance(fs::directory_iterator(dir.path()), fs::directory_iterator{}), before) << "output left behind";
  }
}

TEST(TransferFunctionChoice, HounsfieldCtGetsTheCtPresetOthersARampOverTheirHistogram) {
  Volume ct(ScalarType::Int16, {8, 8, 8});
  for (std::size_t i = 0; i < ct.voxel_count(); ++i) ct.set_value(i, i % 3 == 0 ? -1024.0f : (i % 3 == 1 ? 40.0f : 1200.0f));
  ct.recompute_range();
  EXPECT_EQ(choose_transfer_function(ct), nlohmann::json({{"preset", "ct-bone"}}));

  Volume constant(ScalarType::UInt8, {4, 4, 4});
  constant.recompute_range();
  EXPECT_EQ(choose_transfer_function(constant), nlohmann::json({{"preset", "grayscale"}}));

  // 60% background at 0, the rest uniform over 100..200: the ramp lies inside the foreground
  Volume scan(ScalarType::UInt8, {10, 10, 10});
  for (std::size_t i = 0; i < scan.voxel_count(); ++i) scan.set_value(i, i % 10 < 6 ? 0.0f : 100.0f + static_cast<float>(i % 101));
  scan.recompute_range();
  const nlohmann::json tf = choose_transfer_function(scan);
  ASSERT_TRUE(tf.contains("points"));
  const auto& p = tf["points"];
  EXPECT_GE(p.front()[0].get<double>(), 100.0);  // starts above the background
  EXPECT_LE(p.back()[0].get<double>(), 200.0);
  EXPECT_EQ(p.front()[4].get<double>(), 0.0);
  for (std::size_t i = 1; i < p.size(); ++i) {
    EXPECT_GE(p[i][0].get<double>(), p[i - 1][0].get<double>());  // values rise
    EXPECT_GE(p[i][4].get<double>(), p[i - 1][4].get<double>());  // so does opacity
  }
  EXPECT_GT(p.back()[4].get<double>(), 0.3);
}

TEST(TransferFunctionChoice, AVisibleVolumeWithoutOneGetsTheChosenOne) {
  nlohmann::json j = volume_scene({{"name", "sphere"}, {"size", 20}, {"radius", 0.3}}, {{"preset", "grayscale"}});
  j["volumes"][0].erase("transfer_function");
  j["camera"] = {{"width", 24}, {"height", 24}};
  Engine chosen(j, "");
  const Image a = chosen.render().image;
  nlohmann::json explicit_tf = j;
  explicit_tf["volumes"][0]["transfer_function"] = choose_transfer_function(*chosen.scene().volumes[0].volume);
  const Image b = Engine(explicit_tf, "").render().image;
  EXPECT_EQ(a.pixels(), b.pixels());
  EXPECT_EQ(chosen.saved_document("")["volumes"][0]["transfer_function"], explicit_tf["volumes"][0]["transfer_function"]);
}
