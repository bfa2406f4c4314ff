// Slices (scene key slices[]): a plane through a volume, cut to its box, coloured by the volume's
// trilinear values through a colour map; it receives the shadows of everything and casts none unless
// asked, and an edit of it rebuilds nothing.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <string>

#include "error_message.h"
#include "image_check.h"
#include "penumbra/engine/invalidation.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene_io/scene_file.h"
#include "test_scenes.h"

namespace penumbra::test {
namespace {

using json = nlohmann::json;

// A smooth procedural volume, hidden, and one slice through it; lit by the ambient term alone, so that
// a slice pixel is its colour.
json slice_scene(const json& slice) {
  json j = volume_scene({{"name", "marschner-lobb"}, {"size", 24}}, step_tf(0.5));
  j["volumes"][0]["visible"] = false;
  j["volumes"][0].erase("transfer_function");
  j["volumes"][0].erase("step");
  j["slices"] = json::array({slice});
  j["camera"] = {{"width", 40}, {"height", 40}, {"direction", {0.3, 0.5, 1.0}}};
  j["shading"] = {{"ambient", 1.0}, {"diffuse", 0.0}, {"specular", 0.0}};
  j["background"] = {0, 0, 0};
  return j;
}

TEST(Slice, PixelsAreTheTrilinearSamplesAtTheirWorldPoints) {
  const json slice = {{"normal", {0.2, 0.3, 1.0}}, {"color_map", {{"preset", "mri-head"}}}};
  const Scene scene = build_scene(slice_scene(slice), "");
  ASSERT_EQ(scene.planes.size(), 1u);
  ASSERT_TRUE(scene.planes[0].slice);
  const FrameResult f = Renderer(scene).render();
  const PrimaryRays rays(scene.camera);
  const SliceColors& colors = *scene.planes[0].slice;
  int covered = 0, empty = 0;
  for (int y = 0; y < scene.camera.height; ++y)
    for (int x = 0; x < scene.camera.width; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * scene.camera.width + x;
      const Rgb got = f.image.pixels()[i];
      if (f.depth[i] == kInfinity) {
        EXPECT_EQ(got.max_component(), 0.0f);  // outside the volume's box: nothing
        ++empty;
        continue;
      }
      ++covered;
      const Vec3 p = rays.ray(x, y).at(f.depth[i]);
      EXPECT_TRUE(colors.volume->bounds().contains(p));
      const Rgb want = colors.color_map.evaluate(colors.volume->sample(p)).rgb;
      EXPECT_NEAR(got.r, want.r, 2e-3) << x << "," << y;
      EXPECT_NEAR(got.g, want.g, 2e-3) << x << "," << y;
      EXPECT_NEAR(got.b, want.b, 2e-3) << x << "," << y;
    }
  EXPECT_GT(covered, 300);
  EXPECT_GT(empty, 100);
}

TEST(Slice, AWindowIsGreyFromLoToHi) {
  const Scene scene = build_scene(slice_scene({{"window", {0.2, 0.6}}}), "");
  const SliceColors& c = *scene.planes[0].slice;
  EXPECT_NEAR(c.color_map.evaluate(0.4f).rgb.g, 0.5f, 1e-6);
  EXPECT_EQ(c.color_map.evaluate(0.1f).rgb.r, 0.0f);
  EXPECT_EQ(c.color_map.evaluate(0.9f).rgb.b, 1.0f);
}

// A slice under an opaque sphere set receives its shadow; a slice over a floor casts none unless asked.
TEST(Slice, ReceivesShadowsAndCastsOnlyWhenAsked) {
  auto scene = [](bool slice_casts, bool with_sphere) {
    json j = slice_scene({{"normal", {0, 1, 0}}, {"window", {0, 1}}, {"casts_shadows", slice_casts}});
    j["planes"] = json::array({{{"point", {0, -0.6, 0}}, {"normal", {0, 1, 0}}, {"size", 3}}});
    j["lights"] = json::array({{{"type", "directional"}, {"direction", {0.6, -1.0, 0.0}}}});  // shadows shift by 0.6 per unit down
    j["shading"] = {{"ambient", 0.2}, {"diffuse", 0.8}, {"specular", 0.0}};
    j["shadows"] = {{"technique", "ray_traced"}};
    j["camera"] = {{"width", 48}, {"height", 48}, {"direction", {0.0, 1.0, 0.15}}, {"target", {0, 0, 0}}, {"distance", 4}};
    if (with_sphere) j["particles"] = json::array({{{"procedural", {{"name", "random-spheres"}, {"count", 1}, {"radius", 0.25}, {"seed", 1}}}, {"origin", {-0.48, 0.8, 0}}}});
    return build_scene(j, "");
  };
  const Scene lit = scene(false, false), shaded = scene(false, true), casting = scene(true, false);
  const Image a = Renderer(lit).render().image, b = Renderer(shaded).render().image, c = Renderer(casting).render().image;
  // the centre pixel looks down onto the slice's centre, where the sphere's shadow falls
  const std::size_t centre = 24 * 48 + 24;
  EXPECT_LT(b.pixels()[centre].max_component(), 0.5f * a.pixels()[centre].max_component());
  // the floor beside the slice (the shadow shifted past its edge): lit when the slice does not cast
  EXPECT_GT(compare_images(a, c).max_abs, 0.1);
}

TEST(Slice, BadSlicesAreErrorsNamingTheKey) {
  EXPECT_NE(error_message([&] { build_scene(slice_scene({{"window", {0.6, 0.2}}}), ""); }).find("slices.0.window"), std::string::npos);
  EXPECT_NE(error_message([&] { build_scene(slice_scene({{"opacity", 1.5}}), ""); }).find("slices.0.opacity"), std::string::npos);
  EXPECT_EQ(error_message([&] { build_scene(slice_scene({{"opacity", 0.5}, {"casts_shadows", true}}), ""); }),
            "slices.0.casts_shadows: a translucent slice ('opacity' below 1) casts no shadow: give 'opacity': 1 for a slice that casts");
  EXPECT_NE(error_message([&] { build_scene(slice_scene({{"volume", 3}}), ""); }).find("slices.0.volume"), std::string::npos);
  EXPECT_NE(error_message([&] { build_scene(slice_scene({{"window", {0, 1}}, {"color_map", {{"preset", "mri-head"}}}}), ""); }).find("slices.0.window"),
            std::string::npos);
}

// A translucent slice (opacity a) is the opaque slice over what lies behind it: the volume in front of
// it, the slice, and the volume and floor behind it composite to a·(the frame with the slice opaque) +
// (1 − a)·(the frame without it), whether the volume is visible or hidden. The light's shadows fall on
// it (exact ray-traced shadows: no fit to the receivers, which differ between the three frames).
TEST(Slice, ATranslucentSliceIsTheOpaqueOneBlendedOverWhatIsBehindIt) {
  for (const bool volume_visible : {false, true}) {
    SCOPED_TRACE(volume_visible ? "visible volume" : "hidden volume");
    auto frame = [&](double opacity, bool with_slice) {
      json j = volume_scene({{"name", "marschner-lobb"}, {"size", 24}}, step_tf(0.5));
      j["volumes"][0]["visible"] = volume_visible;
      if (volume_visible)  // faint, so that no ray reaches the early-termination opacity
        j["volumes"][0]["transfer_function"] = {{"points", {{0.0, 0.9, 0.6, 0.3, 0.0}, {1.0, 0.9, 0.6, 0.3, 0.08}}}, {"domain", "normalized"}};
      else
        j["volumes"][0].erase("transfer_function");
      j["volumes"][0]["jitter"] = false;
      if (with_slice) j["slices"] = json::array({{{"normal", {0.2, 0.1, 1.0}}, {"window", {0, 1}}, {"opacity", opacity}}});
      j["planes"] = json::array({{{"point", {0, -0.6, 0}}, {"normal", {0, 1, 0}}, {"size", 3}}});
      j["lights"] = json::array({{{"type", "directional"}, {"direction", {0.3, -1.0, -0.4}}}});
      j["shadows"] = {{"technique", "ray_traced"}};
      j["camera"] = {{"width", 48}, {"height", 40}, {"direction", {0.3, 0.4, 1.0}}, {"target", {0, 0, 0}}, {"distance", 3}};
      return Renderer(build_scene(j, "")).render().image;
    };
    const Image without = frame(1, false), opaque = frame(1, true);
    ASSERT_GT(compare_images(without, opaque).max_abs, 0.1) << "the slice is not in view";
    for (const double a : {0.25, 0.6}) {
      const Image glass = frame(a, true);
      Image expected = opaque;
      for (std::size_t i = 0; i < expected.pixels().size(); ++i)
        expected.pixels()[i] = opaque.pixels()[i] * static_cast<float>(a) + without.pixels()[i] * static_cast<float>(1 - a);
      EXPECT_LT(compare_images(glass, expected).max_abs, 2e-5) << "opacity " << a << ": " << write_failure_images("translucent_slice", glass, expected);
    }
  }
}

// Moving a slice that does not cast rebuilds nothing; one that casts rebuilds what casts.
TEST(Slice, AnEditRebuildsNothingButTheSlice) {
  json j = slice_scene({{"window", {0, 1}}});
  j["shadows"] = {{"technique", "shadow_map"}, {"resolution", 64}};
  SceneDataCache cache;
  SceneReadOptions options;
  options.cache = &cache;
  Renderer r(build_scene(j, "", options));
  (void)r.render();
  j["slices"][0]["point"] = {0, 0, 0.2};
  Scene edited = build_scene(j, "", options);
  r.apply_edit(edited, invalidated_by("slices.0.point", edited));
  const FrameResult f = r.render();
  EXPECT_TRUE(f.rebuilt.empty()) << f.rebuilt.front();
  EXPECT_LT(compare_images(f.image, Renderer(build_scene(j, "", options)).render().image).max_abs, 1e-6);
  j["slices"][0]["casts_shadows"] = true;
  const Scene casting = build_scene(j, "", options);
  const std::vector<std::string> stale = invalidated_by("slices.0.point", casting);
  EXPECT_NE(std::find(stale.begin(), stale.end(), "casters"), stale.end());
}

}  // namespace
}  // namespace penumbra::test
