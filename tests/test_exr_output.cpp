// OpenEXR output (core/exr_io.h, `render -o out.exr [--depth]`): the file round-trips exactly; the
// colour composited over the scene's background is the PFM picture; alpha is 0 where nothing is hit;
// depth equals the closed form for one sphere (eye distance minus radius) and is +inf on background.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <limits>
#include <string>

#include "cli_run.h"
#include "penumbra/core/error.h"
#include "penumbra/core/exr_io.h"
#include "penumbra/core/image_io.h"
#include "test_scenes.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// One carbon atom (van der Waals radius 1.7 Å) at the origin, seen from 10 Å along +z.
std::string one_sphere_scene(const ScratchDir& dir) {
  std::ofstream(dir.file("atom.xyz")) << "1\none carbon\nC 0 0 0\n";
  const std::string path = dir.file("scene.json");
  std::ofstream(path) << R"({
    "particles": [ { "file": "atom.xyz" } ],
    "lights": [ { "type": "directional", "direction": [-0.3, -0.5, -1] } ],
    "camera": { "eye": [0, 0, 10], "target": [0, 0, 0], "fov_deg": 30, "width": 33, "height": 33 },
    "background": [0.2, 0.3, 0.4]
  })";
  return path;
}

}  // namespace

TEST(Exr, WriteThenReadIsExact) {
  ScratchDir dir;
  ExrImage img;
  img.width = 3;
  img.height = 2;
  for (int i = 0; i < 24; ++i) img.rgba.push_back(0.125f * static_cast<float>(i) - 1.0f);
  img.depth = {1.5f, kInf, 0.0f, 1e6f, 3.25f, kInf};
  write_exr(dir.file("a.exr"), img);
  const ExrImage back = read_exr(dir.file("a.exr"));
  EXPECT_EQ(back.width, 3);
  EXPECT_EQ(back.height, 2);
  EXPECT_EQ(back.rgba, img.rgba);
  EXPECT_EQ(back.depth, img.depth);
  img.depth.clear();
  write_exr(dir.file("b.exr"), img);
  EXPECT_TRUE(read_exr(dir.file("b.exr")).depth.empty()) << "no Z channel unless asked";
}

TEST(Exr, BadInputIsAnErrorNamingTheFile) {
  ScratchDir dir;
  std::ofstream(dir.file("bad.exr")) << "not an exr";
  try {
    (void)read_exr(dir.file("bad.exr"));
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.exr"), std::string::npos) << e.what();
  }
  ExrImage wrong;
  wrong.width = wrong.height = 2;
  wrong.rgba.resize(3);
  EXPECT_THROW(write_exr(dir.file("w.exr"), wrong), Error);
  EXPECT_FALSE(std::filesystem::exists(dir.file("w.exr")));
}

TEST(Exr, RenderWritesPremultipliedRgbaAndDepth) {
  ScratchDir dir;
  const std::string scene = one_sphere_scene(dir);
  const CliRun pfm = penumbra_cli("render " + quote(scene) + " -o " + quote(dir.file("a.pfm")) + " --threads 1");
  ASSERT_EQ(pfm.status, 0) << pfm.err;
  const CliRun exr = penumbra_cli("render " + quote(scene) + " -o " + quote(dir.file("a.exr")) + " --depth --threads 1");
  ASSERT_EQ(exr.status, 0) << exr.err;
  const Image picture = read_image(dir.file("a.pfm"));
  const ExrImage e = read_exr(dir.file("a.exr"));
  ASSERT_EQ(e.width, 33);
  ASSERT_EQ(e.height, 33);
  ASSERT_EQ(e.depth.size(), 33u * 33u);
  const Rgb background(0.2f, 0.3f, 0.4f);
  int hit = 0, empty = 0;
  for (int y = 0; y < 33; ++y)
    for (int x = 0; x < 33; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * 33 + static_cast<std::size_t>(x);
      const float a = e.rgba[4 * i + 3];
      for (int c = 0; c < 3; ++c)  // colour + background (1 - alpha) is the PFM picture
        EXPECT_NEAR(e.rgba[4 * i + c] + background[c] * (1 - a), picture.at(x, y)[c], 1e-5f) << x << "," << y;
      if (a == 0.0f) {
        ++empty;
        EXPECT_EQ(e.depth[i], kInf) << x << "," << y;
        EXPECT_EQ(e.rgba[4 * i], 0.0f);
      } else {
        ++hit;
        EXPECT_TRUE(std::isfinite(e.depth[i])) << x << "," << y;
      }
    }
  EXPECT_GT(hit, 20);
  EXPECT_GT(empty, 200);
  EXPECT_EQ(e.rgba[4 * (16 * 33 + 16) + 3], 1.0f);
  EXPECT_NEAR(e.depth[16 * 33 + 16], 10.0f - 1.7f, 0.02f) << "the centre ray meets the sphere 1.7 Å before its centre";
}

TEST(Exr, DepthNeedsAnExrAndBadExtensionsFail) {
  ScratchDir dir;
  const std::string scene = one_sphere_scene(dir);
  const CliRun r = penumbra_cli("render " + quote(scene) + " -o " + quote(dir.file("a.png")) + " --depth");
  EXPECT_NE(r.status, 0);
  EXPECT_NE(r.err.find("--depth"), std::string::npos) << r.err;
  const CliRun bad = penumbra_cli("render " + quote(scene) + " -o " + quote(dir.file("a.tiff")));
  EXPECT_NE(bad.status, 0);
  EXPECT_NE(bad.err.find(".exr"), std::string::npos) << bad.err;
  EXPECT_FALSE(std::filesystem::exists(dir.file("a.png")));
}
