// Tests for transfer_function.h: evaluation, validation, presets, the scene-file JSON form, ParaView
// import, opacity correction and the lookup table with its visibility prefix count.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>

#include "penumbra/core/error.h"
#include "penumbra/core/rng.h"
#include "penumbra/data/colormaps.h"
#include "penumbra/data/transfer_function.h"
#include "error_message.h"

using namespace penumbra;
using penumbra::test::error_message;
using nlohmann::json;

namespace {

void expect_rgba(const Rgba& c, float r, float g, float b, float a, float tol = 1e-5f) {
  EXPECT_NEAR(c.rgb.r, r, tol);
  EXPECT_NEAR(c.rgb.g, g, tol);
  EXPECT_NEAR(c.rgb.b, b, tol);
  EXPECT_NEAR(c.a, a, tol);
}

TransferFunction parse(const std::string& text, float lo = 0, float hi = 1) {
  return parse_transfer_function(json::parse(text), lo, hi, "");
}

}  // namespace

TEST(TransferFunction, EvaluatesAtBetweenAndBeyondPoints) {
  // Given out of order: the constructor sorts.
  const TransferFunction tf({{10, Rgb(1, 0, 0), 0.5f}, {0, Rgb(0, 0, 1), 0.0f}, {20, Rgb(0, 1, 0), 1.0f}});
  ASSERT_EQ(tf.points().size(), 3u);
  EXPECT_EQ(tf.points()[0].value, 0);
  expect_rgba(tf.evaluate(0), 0, 0, 1, 0);
  expect_rgba(tf.evaluate(10), 1, 0, 0, 0.5f);
  expect_rgba(tf.evaluate(20), 0, 1, 0, 1);
  expect_rgba(tf.evaluate(5), 0.5f, 0, 0.5f, 0.25f);
  expect_rgba(tf.evaluate(17.5f), 0.25f, 0.75f, 0, 0.875f);
  expect_rgba(tf.evaluate(-100), 0, 0, 1, 0);  // constant beyond the ends
  expect_rgba(tf.evaluate(1e6f), 0, 1, 0, 1);
}

TEST(TransferFunction, DuplicateValuesMakeAStep) {
  const TransferFunction tf({{0, Rgb(0), 0.0f}, {1, Rgb(0), 0.0f}, {1, Rgb(1), 1.0f}, {2, Rgb(1), 1.0f}});
  EXPECT_NEAR(tf.evaluate(0.999f).a, 0.0f, 1e-3f);
  EXPECT_EQ(tf.evaluate(1.0f).a, 1.0f);
  EXPECT_EQ(tf.evaluate(1.5f).a, 1.0f);
}

TEST(TransferFunction, RejectsInvalidPoints) {
  EXPECT_THROW(TransferFunction(std::vector<TransferPoint>{}), Error);
  const std::string nan_msg = error_message([] { TransferFunction({{0, Rgb(0), 0}, {std::nanf(""), Rgb(0), 0}}); });
  EXPECT_NE(nan_msg.find("point 1"), std::string::npos) << nan_msg;
  EXPECT_THROW(TransferFunction({{INFINITY, Rgb(0), 0}}), Error);
  const std::string col_msg = error_message([] { TransferFunction({{0, Rgb(0), 0}, {7, Rgb(0, 1.5f, 0), 0}}); });
  EXPECT_NE(col_msg.find("point 1"), std::string::npos) << col_msg;
  EXPECT_NE(col_msg.find("7"), std::string::npos) << col_msg;
  EXPECT_NE(col_msg.find("1.5"), std::string::npos) << col_msg;
  EXPECT_THROW(TransferFunction({{0, Rgb(0), -0.1f}}), Error);
  EXPECT_THROW(TransferFunction({{0, Rgb(0), 1.01f}}), Error);
  EXPECT_THROW(TransferFunction({{0, Rgb(-0.01f, 0, 0), 0.5f}}), Error);
}

TEST(TransferFunction, EveryPresetHasVisibleAndTransparentValues) {
  const auto names = transfer_function_preset_names();
  ASSERT_EQ(names.size(), 5u + colormap_names().size());
  for (const std::string& name : names) {
    // Each on the range of the data it is meant for.
    const bool ct = name.rfind("ct-", 0) == 0;
    const float lo = ct ? -1024.0f : 0.0f, hi = ct ? 3071.0f : (name == "mri-head" ? 255.0f : 1.0f);
    const TransferFunction tf = parse_transfer_function(json{{"preset", name}}, lo, hi, "");
    int visible = 0, clear = 0;
    for (int i = 0; i <= 1000; ++i) {
      const float a = tf.evaluate(lo + (hi - lo) * static_cast<float>(i) / 1000.0f).a;
      (a > 0 ? visible : clear) += 1;
    }
    EXPECT_GT(visible, 10) << name;
    // The background (air, empty space) is transparent; grayscale's ramp is clear only there.
    const bool ramp = name == "grayscale" || colormap_samples(name) != nullptr;
    EXPECT_GE(clear, ramp ? 1 : 10) << name;
    EXPECT_EQ(tf.evaluate(lo).a, 0.0f) << name;
  }
  // Bone presets: air transparent, dense bone nearly opaque and bright.
  const TransferFunction bone = parse(R"({"preset": "ct-bone"})", -1024, 3033);
  EXPECT_EQ(bone.evaluate(-1000).a, 0.0f);
  EXPECT_EQ(bone.evaluate(40).a, 0.0f);  // soft tissue
  EXPECT_GT(bone.evaluate(1000).a, 0.6f);
  EXPECT_GT(bone.evaluate(1000).rgb.average(), 0.6f);
  const TransferFunction soft = parse(R"({"preset": "ct-soft-tissue"})", -1024, 3033);
  EXPECT_GT(soft.evaluate(-450).a, 0.0f);
  EXPECT_LT(soft.evaluate(-450).a, 0.5f);
  EXPECT_GT(soft.evaluate(1000).a, 0.8f);
}

TEST(TransferFunction, UnknownPresetListsKnownNames) {
  const std::string msg = error_message([] { parse(R"({"preset": "ct-lungs"})"); });
  EXPECT_NE(msg.find("ct-lungs"), std::string::npos) << msg;
  for (const std::string& name : transfer_function_preset_names()) EXPECT_NE(msg.find(name), std::string::npos) << msg;
}

TEST(TransferFunction, NormalizedDomainMapsOntoDataRange) {
  const TransferFunction tf = parse(R"({"points": [[0, 0,0,0, 0], [0.5, 1,1,1, 1]], "domain": "normalized"})", 100, 300);
  EXPECT_FLOAT_EQ(tf.points()[0].value, 100.0f);
  EXPECT_FLOAT_EQ(tf.points()[1].value, 200.0f);
  EXPECT_NEAR(tf.evaluate(150).a, 0.5f, 1e-6f);
  const TransferFunction data = parse(R"({"points": [[0, 0,0,0, 0], [0.5, 1,1,1, 1]], "domain": "data"})", 100, 300);
  EXPECT_FLOAT_EQ(data.points()[1].value, 0.5f);
  // Normalised presets follow the data range too.
  const TransferFunction gray = parse(R"({"preset": "grayscale"})", -10, 30);
  EXPECT_FLOAT_EQ(gray.points().front().value, -10.0f);
  EXPECT_FLOAT_EQ(gray.points().back().value, 30.0f);
  expect_rgba(gray.evaluate(10), 0.5f, 0.5f, 0.5f, 0.25f);
}

TEST(TransferFunction, JsonPointsInBothForms) {
  const TransferFunction arrays = parse(R"({"points": [[2, 1, 0.5, 0, 0.25], [-1, 0, 0, 1, 0]]})");
  const TransferFunction objects = parse(
      R"({"points": [{"value": 2, "color": [1, 0.5, 0], "alpha": 0.25}, {"value": -1, "color": [0, 0, 1], "alpha": 0}]})");
  for (const float v : {-2.0f, -1.0f, 0.0f, 0.5f, 2.0f, 3.0f}) {
    const Rgba a = arrays.evaluate(v), b = objects.evaluate(v);
    expect_rgba(a, b.rgb.r, b.rgb.g, b.rgb.b, b.a);
  }
  expect_rgba(arrays.evaluate(2), 1, 0.5f, 0, 0.25f);
}

TEST(TransferFunction, OpacityScaleMultipliesAndClamps) {
  const TransferFunction tf = parse(R"({"points": [[0, 1,1,1, 0.2], [1, 1,1,1, 0.6]], "opacity_scale": 2})");
  EXPECT_NEAR(tf.evaluate(0).a, 0.4f, 1e-6f);
  EXPECT_EQ(tf.evaluate(1).a, 1.0f);
  EXPECT_THROW(parse(R"({"preset": "grayscale", "opacity_scale": -1})"), Error);
}

TEST(TransferFunction, ParseErrorsNameKeyAndValue) {
  auto expect_msg = [](const std::string& text, const std::string& part) {
    const std::string msg = error_message([&] { parse(text); });
    EXPECT_NE(msg.find(part), std::string::npos) << text << " -> " << msg;
  };
  expect_msg(R"({"preset": "grayscale", "colour": 1})", "colour");
  expect_msg(R"({"preset": 3})", "preset");
  expect_msg(R"({})", "exactly one");
  expect_msg(R"({"preset": "grayscale", "points": [[0,0,0,0,0]]})", "exactly one");
  expect_msg(R"({"points": [[0,0,0,0,0]], "domain": "hounsfield"})", "hounsfield");
  expect_msg(R"({"points": [[0,0,0,0]]})", "points[0]");
  expect_msg(R"({"points": [[0,0,0,0,"a"]]})", "points[0][4]");
  expect_msg(R"({"points": [{"value": 0, "color": [0,0], "alpha": 0}]})", "points[0].color");
  expect_msg(R"({"points": [{"value": 0, "colour": [0,0,0], "alpha": 0}]})", "colour");
  expect_msg(R"({"points": []})", "points");
  expect_msg(R"({"paraview": "no_such_file.json"})", "no_such_file.json");
  expect_msg(R"({"preset": "grayscale", "opacity_scale": "x"})", "opacity_scale");
}

TEST(TransferFunction, ParaviewFileIsResolvedAgainstBaseDir) {
  const std::filesystem::path dir = std::filesystem::path(::testing::TempDir()) / "penumbra_tf_test";
  std::filesystem::create_directories(dir);
  std::ofstream(dir / "map.json") << R"([{"Name": "A", "RGBPoints": [0, 0, 0, 0, 10, 1, 1, 1],
                                          "Points": [0, 0, 0.5, 0, 10, 0.5, 0.5, 0]}])";
  const TransferFunction tf = parse_transfer_function(json{{"paraview", "map.json"}, {"name", "A"}}, 0, 1, dir.string());
  EXPECT_NEAR(tf.evaluate(10).a, 0.5f, 1e-6f);
  EXPECT_NEAR(tf.evaluate(5).a, 0.25f, 1e-6f);
  EXPECT_THROW(parse_transfer_function(json{{"paraview", "map.json"}, {"name", "B"}}, 0, 1, dir.string()), Error);
  std::ofstream(dir / "bad.json") << "[{";
  EXPECT_THROW(parse_transfer_function(json{{"paraview", "bad.json"}}, 0, 1, dir.string()), Error);
}

TEST(TransferFunction, ParaviewImportListSingleObjectAndNames) {
  const json list = json::parse(R"([
    {"ColorSpace": "Diverging", "Name": "Cool to Warm",
     "RGBPoints": [-100, 0, 0, 1, 100, 1, 0, 0], "Points": [-100, 0, 0.5, 0, 100, 0.8, 0.5, 0]},
    {"Name": "Ramp", "RGBPoints": [0, 0, 0, 0, 50, 1, 1, 1]}])");
  const TransferFunction first = import_paraview_colormap(list, "");
  expect_rgba(first.evaluate(-100), 0, 0, 1, 0);
  expect_rgba(first.evaluate(100), 1, 0, 0, 0.8f);
  EXPECT_NEAR(first.evaluate(0).a, 0.4f, 1e-6f);  // positions stay in data units
  // Without "Points": opacity ramps 0 -> 1 over the RGBPoints range.
  const TransferFunction ramp = import_paraview_colormap(list, "Ramp");
  EXPECT_NEAR(ramp.evaluate(0).a, 0.0f, 1e-6f);
  EXPECT_NEAR(ramp.evaluate(25).a, 0.5f, 1e-6f);
  EXPECT_NEAR(ramp.evaluate(50).a, 1.0f, 1e-6f);
  // ParaView colours are display values: 0 and 1 are unchanged, mid grey becomes linear.
  EXPECT_NEAR(ramp.evaluate(50).rgb.g, 1.0f, 1e-6f);
  const TransferFunction single = import_paraview_colormap(list[1], "");
  EXPECT_NEAR(single.evaluate(25).a, 0.5f, 1e-6f);
  EXPECT_THROW(import_paraview_colormap(list, "Viridis"), Error);
  EXPECT_THROW(import_paraview_colormap(list[1], "Viridis"), Error);
}

TEST(TransferFunction, ParaviewMergesColourAndOpacityNodes) {
  const json preset = json::parse(
      R"({"RGBPoints": [0, 0, 0, 0, 10, 1, 1, 1], "Points": [5, 0, 0.5, 0, 15, 1, 0.5, 0]})");
  const TransferFunction tf = import_paraview_colormap(preset, "");
  ASSERT_EQ(tf.points().size(), 4u);  // positions 0, 5, 10, 15
  EXPECT_NEAR(tf.evaluate(10).a, 0.5f, 1e-6f);       // opacity evaluated at a colour node
  EXPECT_NEAR(tf.evaluate(5).rgb.r, srgb_to_linear(0.5f), 1e-6f);  // colour evaluated at an opacity node
  EXPECT_NEAR(tf.evaluate(15).rgb.r, 1.0f, 1e-6f);
  EXPECT_NEAR(tf.evaluate(0).a, 0.0f, 1e-6f);
}

TEST(TransferFunction, ParaviewRejectsMalformedNodeLists) {
  EXPECT_THROW(import_paraview_colormap(json::parse(R"({"RGBPoints": [0, 0, 0, 0, 1, 1, 1]})"), ""), Error);
  const std::string msg =
      error_message([] { import_paraview_colormap(json::parse(R"({"RGBPoints": [0, 0, 0, 0, 1, 1, 1]})"), ""); });
  EXPECT_NE(msg.find("RGBPoints"), std::string::npos) << msg;
  EXPECT_NE(msg.find("7"), std::string::npos) << msg;
  EXPECT_THROW(import_paraview_colormap(json::parse(R"({"RGBPoints": [0, 0, 0, 0], "Points": [0, 1, 0.5]})"), ""), Error);
  EXPECT_THROW(import_paraview_colormap(json::parse(R"({"Points": [0, 1, 0.5, 0]})"), ""), Error);
  EXPECT_THROW(import_paraview_colormap(json::parse(R"({"RGBPoints": [0, 2, 0, 0]})"), ""), Error);
  EXPECT_THROW(import_paraview_colormap(json::parse("[]"), ""), Error);
  EXPECT_THROW(import_paraview_colormap(json::parse("3"), ""), Error);
}

TEST(TransferFunction, OpacityCorrectionClosedForm) {
  for (const float a : {0.0f, 0.01f, 0.3f, 0.75f, 1.0f}) {
    EXPECT_NEAR(opacity_correct(a, 1.0f), a, 1e-6f);
    EXPECT_NEAR(opacity_correct(a, 2.0f), 1.0f - (1.0f - a) * (1.0f - a), 1e-6f);
    EXPECT_NEAR(opacity_correct(a, 0.37f), 1.0f - std::pow(1.0f - a, 0.37f), 1e-6f);
  }
  EXPECT_EQ(opacity_correct(1.0f, 0.01f), 1.0f);
  EXPECT_EQ(opacity_correct(0.0f, 5.0f), 0.0f);
  // Compositing two half steps transmits as much as one full step.
  for (const float a : {0.05f, 0.5f, 0.9f}) {
    const float half = opacity_correct(a, 0.5f);
    const float two_halves = 1.0f - (1.0f - half) * (1.0f - half);
    EXPECT_NEAR(two_halves, a, 1e-6f);
    EXPECT_NEAR(opacity_correct(opacity_correct(a, 0.5f), 2.0f), a, 1e-6f);
  }
}

TEST(TransferFunction, LutMatchesEvaluateWithCorrectedOpacity) {
  const TransferFunction bone = parse(R"({"preset": "ct-bone"})", -1024, 3071);
  // Slopes of a few units per unit value: a linear table of 4096 entries then stays within 1e-3.
  const TransferFunction custom({{0, Rgb(0, 0, 1), 0}, {0.3f, Rgb(1, 0, 0), 0.6f}, {0.6f, Rgb(0, 1, 0), 0.2f},
                                 {0.9f, Rgb(1, 1, 1), 0.9f}});
  struct Case { const TransferFunction* tf; float lo, hi, ratio; };
  for (const Case& c : {Case{&bone, -1024, 3071, 1.0f}, Case{&bone, -1024, 3071, 0.5f}, Case{&custom, -0.2f, 1.2f, 0.7f}}) {
    const TransferLut lut(*c.tf, c.lo, c.hi, c.ratio);
    EXPECT_EQ(lut.size(), 4096);
    for (std::uint64_t i = 0; i < 2000; ++i) {
      const float v = c.lo + (c.hi - c.lo) * (1.2f * uniform_float(7, i) - 0.1f);  // also outside the range
      const Rgba want = c.tf->evaluate(std::clamp(v, c.lo, c.hi));
      const Rgba got = lut.lookup(v);
      expect_rgba(got, want.rgb.r, want.rgb.g, want.rgb.b, opacity_correct(want.a, c.ratio), 1e-3f);
    }
  }
  const TransferLut degenerate(custom, 5, 5, 1.0f, 16);
  EXPECT_EQ(degenerate.hi(), 6.0f);
  EXPECT_THROW(TransferLut(custom, 0, 1, 1.0f, 1), Error);
}

TEST(TransferFunction, AnyVisibleAgreesWithBruteForce) {
  // Visible bumps placed off the table's grid so the brute force below is not a rounding contest.
  const TransferFunction tf({{0.2013f, Rgb(1), 0}, {0.2511f, Rgb(1), 0.5f}, {0.3027f, Rgb(1), 0},
                             {0.7107f, Rgb(1), 0}, {0.7219f, Rgb(1), 0.3f}, {0.7312f, Rgb(1), 0}});
  const int size = 64;
  const float lo = 0, hi = 1;
  const TransferLut lut(tf, lo, hi, 1.0f, size);
  const float scale = static_cast<float>(size - 1) / (hi - lo);
  int visible_cases = 0;
  for (std::uint64_t i = 0; i < 3000; ++i) {
    float a = 1.2f * uniform_float(11, i, 0) - 0.1f, b = 1.2f * uniform_float(11, i, 1) - 0.1f;
    if (i % 3 == 0) b = a + 0.02f * uniform_float(11, i, 2);  // many short intervals
    if (a > b) std::swap(a, b);
    const int first = static_cast<int>(std::floor(std::clamp((a - lo) * scale, 0.0f, size - 1.0f)));
    const int last = static_cast<int>(std::ceil(std::clamp((b - lo) * scale, 0.0f, size - 1.0f)));
    bool brute = false;
    for (int k = first; k <= last; ++k)
      brute = brute || tf.evaluate(lo + (hi - lo) * static_cast<float>(k) / (size - 1)).a > 0;
    ASSERT_EQ(lut.any_visible(a, b), brute) << "[" << a << ", " << b << "]";
    visible_cases += brute;
    if (!lut.any_visible(a, b)) {  // conservative: no fetch inside [a, b] can see anything
      for (int s = 0; s <= 50; ++s) ASSERT_EQ(lut.lookup(a + (b - a) * static_cast<float>(s) / 50.0f).a, 0.0f);
    }
  }
  EXPECT_GT(visible_cases, 300);
  EXPECT_LT(visible_cases, 2700);
}

// Matplotlib's maps by name span the data's range: viridis runs from its dark purple (#440154) to its
// yellow (#fde725), through the teal of its middle sample, in linear RGB; names ignore case.
TEST(TransferFunction, MatplotlibColourMapsSpanTheDataRange) {
  const TransferFunction tf = parse_transfer_function(json("Viridis"), 100.0f, 300.0f, "");
  const auto linear = [](float r, float g, float b) { return Rgb(srgb_to_linear(r), srgb_to_linear(g), srgb_to_linear(b)); };
  const Rgb first = linear(0x44 / 255.0f, 0x01 / 255.0f, 0x54 / 255.0f), last = linear(0xfd / 255.0f, 0xe7 / 255.0f, 0x25 / 255.0f);
  const auto& mid = (*colormap_samples("viridis"))[16];
  for (int c = 0; c < 3; ++c) {
    EXPECT_NEAR(tf.evaluate(100.0f).rgb[c], first[c], 0.003f);
    EXPECT_NEAR(tf.evaluate(300.0f).rgb[c], last[c], 0.003f);
    EXPECT_NEAR(tf.evaluate(200.0f).rgb[c], linear(mid[0], mid[1], mid[2])[c], 1e-5f);
  }
  EXPECT_EQ(tf.evaluate(100.0f).a, 0.0f);
  EXPECT_NEAR(tf.evaluate(300.0f).a, 0.5f, 1e-6f);
  EXPECT_EQ(colormap_samples("no-such-map"), nullptr);
  EXPECT_EQ(colormap_samples("GREY"), colormap_samples("gray"));
}
