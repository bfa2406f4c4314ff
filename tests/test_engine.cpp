// The interactive engine (engine/engine.h): edits by path rebuild exactly what the invalidation table
// declares and give the image a fresh render of the edited scene gives; refused edits change nothing;
// accumulation converges; a frame can be cancelled; buffers hold what they promise.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <fstream>

#include "penumbra/core/cancel.h"
#include "penumbra/core/progress.h"
#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/engine/engine.h"
#include "penumbra/engine/invalidation.h"
#include "image_check.h"
#include "test_scenes.h"

using namespace penumbra;
using namespace penumbra::test;
using nlohmann::json;

namespace {

// Every kind of object, two lights (one directional, one point), cssm and ray-traced ambient occlusion.
json mixed_scene() {
  json j;
  j["volumes"] = json::array({
      {{"procedural", {{"name", "sphere"}, {"size", 20}, {"radius", 0.3}}}, {"origin", {-0.5, 0.0, -0.5}}, {"transfer_function", step_tf(0.6, 0.9, 0.5, 0.3)}},
      {{"procedural", {{"name", "slab"}, {"size", 20}, {"thickness", 0.3}}}, {"origin", {-0.5, -0.9, -0.5}}, {"visible", false}},
  });
  j["isosurfaces"] = json::array({{{"volume", 1}, {"value", 0.5}, {"method", "raycast"}}});
  j["particles"] = json::array({
      {{"procedural", {{"name", "random-spheres"}, {"count", 30}, {"radius", 0.05}, {"seed", 3}}}, {"origin", {0.5, 0.3, 0.2}}},
      {{"procedural", {{"name", "random-spheres"}, {"count", 20}, {"radius", 0.04}, {"seed", 4}}}, {"origin", {-0.4, 0.4, 0.4}}, {"casts_shadows", false}},
  });
  j["planes"] = json::array({{{"point", {0, -0.8, 0}}, {"normal", {0, 1, 0}}, {"size", 3}}});
  j["lights"] = json::array({{{"type", "directional"}, {"direction", {-0.3, -1, -0.2}}}, {{"type", "point"}, {"position", {1.2, 1.5, 1.0}}, {"intensity", 0.6}}});
  j["shadows"] = {{"technique", "cssm"}, {"resolution", 64}};
  j["ambient"] = {{"technique", "ray_traced_ao"}, {"rays", 4}};
  j["camera"] = {{"width", 40}, {"height", 36}};
  return j;
}

// One volume under the extinction techniques (the SAT and the light cache).
json extinction_scene() {
  json j = volume_scene({{"name", "test-spheres"}, {"size", 24}}, {{"preset", "test-spheres"}});
  j["volumes"][0]["compositing"] = "extinction";
  j["shadows"] = {{"technique", "sat_cone"}};
  j["ambient"] = {{"technique", "sat_shells"}};
  j["light_cache"] = {{"resolution", 24}};
  j["camera"] = {{"width", 36}, {"height", 36}};
  return j;
}

std::vector<std::string> sorted(std::vector<std::string> v) {
  std::sort(v.begin(), v.end());
  return v;
}

std::vector<std::string> names(const EngineFrame& f) {
  std::vector<std::string> n;
  for (const auto& r : f.rebuilt) n.push_back(r.structure);
  return sorted(n);
}

// What the table says an edit of `path` rebuilds, given what the renderer held before and after: the
// declared structures and those that appeared or went away, with everything built from them, among
// those held after.
std::vector<std::string> expected_rebuilt(const std::string& path, const Scene& edited, const std::vector<std::string>& before,
                                          const std::vector<std::string>& after) {
  std::vector<std::string> declared = invalidated_by(path, edited);
  if (declared == std::vector<std::string>{"scene"}) return after;
  for (const auto& s : before)
    if (!std::binary_search(after.begin(), after.end(), s)) declared.push_back(s);
  for (const auto& s : after)
    if (!std::binary_search(before.begin(), before.end(), s)) declared.push_back(s);
  std::vector<std::string> out;
  for (const auto& s : with_dependents(declared, edited))
    if (std::binary_search(after.begin(), after.end(), s)) out.push_back(s);
  return out;
}

void check_edit(const json& base, const std::string& path, const json& value) {
  SCOPED_TRACE(path + " = " + value.dump());
  Engine engine(base, "");
  engine.render();
  const std::vector<std::string> before = engine.renderer().structures();
  engine.set(path, value);
  const EngineFrame f = engine.render();
  const std::vector<std::string> after = engine.renderer().structures();
  EXPECT_EQ(names(f), expected_rebuilt(path, engine.scene(), before, after));
  for (const auto& r : f.rebuilt) EXPECT_EQ(r.cause, path) << r.structure;
  EXPECT_EQ(f.edits, std::vector<std::string>{path});
  // the same picture as a renderer made for the edited scene
  const Image fresh = Renderer(build_scene(engine.document(), "")).render().image;
  FailureImages keep;
  keep.add("edited_vs_fresh", f.image, fresh);
  ASSERT_EQ(f.image.pixels().size(), fresh.pixels().size());
  EXPECT_EQ(std::memcmp(f.image.pixels().data(), fresh.pixels().data(), fresh.pixels().size() * sizeof(Rgb)), 0);
}

}  // namespace

// Proves, for every kind of path the table covers, that an edit rebuilds exactly what the table
// declares (with what depends on it, and what the edited scene newly needs or drops) and that the
// edited engine's image is byte for byte a fresh render of the edited scene.
TEST(Engine, EveryEditRebuildsWhatTheTableSaysAndMatchesAFreshRender) {
  const json base = mixed_scene();
  const std::vector<std::pair<std::string, json>> edits = {
      {"camera.eye", {1.5, 1.0, 2.0}},
      {"background", {0.3, 0.1, 0.1}},
      {"shading.ambient", 0.4},
      {"lights.0.direction", {0.2, -1, -0.4}},
      {"lights.1.position", {-1.0, 1.2, 0.8}},
      {"lights.1.color", {1.0, 0.6, 0.6}},
      {"lights.0.intensity", 0.5},
      {"lights", json::array({{{"type", "directional"}, {"direction", {0, -1, 0}}}})},
      {"volumes.0.transfer_function", step_tf(0.3, 0.2, 0.6, 0.9)},
      {"volumes.0.shadow_transfer_function", step_tf(0.9, 0.2, 0.2, 0.2)},
      {"volumes.0.compositing", "extinction"},
      {"volumes.0.step", 0.8},
      {"volumes.0.jitter", false},
      {"volumes.0.casts_shadows", false},
      {"volumes.0.receives_shadows", false},
      {"volumes.0.procedural.radius", 0.2},
      {"volumes.0.origin", {-0.4, 0.0, -0.5}},
      {"particles.0.procedural.seed", 9},
      {"particles.0.casts_shadows", false},
      {"particles.1.receives_shadows", false},
      {"isosurfaces.0.value", 0.3},
      {"isosurfaces.0.color", {0.2, 0.8, 0.2}},
      {"isosurfaces.0.method", "mesh"},
      {"isosurfaces.0.method", "points"},
      {"isosurfaces.0.casts_shadows", false},
      {"isosurfaces.0.receives_shadows", false},
      {"planes.0.point", {0, -0.7, 0}},
      {"planes.0.color", {0.5, 0.5, 0.9}},
      {"planes.0.casts_shadows", false},
      {"planes.0.receives_shadows", false},
      {"shadows.technique", "ray_traced"},
      {"shadows.technique", "shadow_map"},
      {"shadows.spheres", "issm"},
      {"shadows.resolution", 32},
      {"shadows.step", 2},
      {"shadows.seed", 5},
      {"ambient.technique", "none"},
      {"ambient.rays", 8},
      {"sphere_renderer", "embree"},
      {"memory_budget", "64M"},
  };
  for (const auto& [path, value] : edits) check_edit(base, path, value);
}

TEST(Engine, ExtinctionEditsRebuildTheSatAndTheLightCache) {
  const json base = extinction_scene();
  for (const auto& [path, value] : std::vector<std::pair<std::string, json>>{
           {"light_cache.resolution", 16},
           {"ambient.bleeding", 0.5},
           {"ambient.shells", 2},
           {"shadows.cone_angle", 8},
           {"volumes.0.transfer_function", {{"preset", "test-spheres"}, {"opacity_scale", 2}}},
           {"shadows.technique", "cssm"},
           {"ambient.technique", "none"},
       })
    check_edit(base, path, value);
}

// Particle colours reach the image without rebuilding the sphere set, the BVH or any shadow.
TEST(Engine, ParticleColoursRebuildOnlyTheColours) {
  ScratchDir dir;
  const std::string xyz = dir.file("atoms.xyz");
  {
    std::ofstream out(xyz);
    out << "3\ncolours\nC 0 0 0\nO 0.5 0 0\nN 0 0.5 0\n";
  }
  json j;
  j["particles"] = json::array({{{"file", xyz}, {"radius", 0.2}}});
  j["shadows"] = {{"technique", "ray_traced"}};
  j["camera"] = {{"width", 32}, {"height", 32}};
  check_edit(j, "particles.0.color_by", "uniform");
  check_edit(j, "particles.0.radius", 0.25);
}

// A selection edit rebuilds the spheres and what hangs off them, and the image is a fresh render's.
TEST(Engine, SelectionEditRebuildsTheSpheres) {
  ScratchDir dir;
  const std::string xyz = dir.file("atoms.xyz");
  {
    std::ofstream out(xyz);
    out << "3\nselection\nC 0 0 0\nO 0.5 0 0\nN 0 0.5 0\n";
  }
  json j;
  j["particles"] = json::array({{{"file", xyz}, {"radius", 0.2}, {"select", "all"}}});
  j["shadows"] = {{"technique", "ray_traced"}};
  j["camera"] = {{"width", 32}, {"height", 32}};
  check_edit(j, "particles.0.select", "name C O");
  Engine engine(j, "");
  engine.render();
  engine.set("particles.0.select", "name N");
  const EngineFrame f = engine.render();
  EXPECT_NE(std::find_if(f.rebuilt.begin(), f.rebuilt.end(), [](const auto& r) { return r.structure == "spheres"; }), f.rebuilt.end());
  EXPECT_EQ(engine.scene().particles[0].set->size(), 1u);
  EXPECT_EQ(engine.scene().particles[0].selected_atoms, std::optional<std::size_t>(1));
}

// Each pixel's nearest sphere is found again only when what the eye sees of the spheres can change:
// a light edit keeps it (and the image is still a fresh render's), a camera, sphere or rasterizer edit
// finds it again.
TEST(Engine, VisibleSpheresAreKeptUntilTheCameraOrTheSpheresChange) {
  json j;
  j["particles"] = json::array({{{"procedural", {{"name", "random-spheres"}, {"count", 60}, {"radius", 0.08}, {"seed", 2}}}}});
  j["lights"] = json::array({{{"type", "directional"}, {"direction", {-0.3, -1, -0.2}}}});
  j["shadows"] = {{"technique", "issm"}, {"resolution", 64}};
  j["camera"] = {{"width", 48}, {"height", 40}};
  Engine engine(j, "");
  EXPECT_GT(engine.render().frame.hits_ms, 0.0);
  auto after = [&](const std::string& path, const json& value, bool found_again) {
    SCOPED_TRACE(path);
    engine.set(path, value);
    const EngineFrame f = engine.render();
    EXPECT_EQ(f.frame.hits_ms > 0.0, found_again);
    EXPECT_GT(f.frame.sphere_pixels, 0u);
    const Image fresh = Renderer(build_scene(engine.document(), "")).render().image;
    ASSERT_EQ(f.image.pixels().size(), fresh.pixels().size());
    EXPECT_EQ(std::memcmp(f.image.pixels().data(), fresh.pixels().data(), fresh.pixels().size() * sizeof(Rgb)), 0);
  };
  after("lights.0.direction", {0.4, -1, 0.1}, false);
  after("shading.ambient", 0.3, false);
  after("camera.eye", {1.8, 1.2, 2.2}, true);
  after("particles.0.procedural.seed", 5, true);
  after("sphere_renderer", "embree", true);
  after("lights.0.direction", {0.1, -1, 0.3}, false);
}

// The surfaces the camera sees (each pixel's point, normal, colour) are listed again only when they can
// change: a light, shadow or shading edit shades the last frame's list, any other edit lists them anew,
// and every frame equals a fresh render's.
TEST(Engine, VisibleSurfacesAreKeptWhileOnlyTheLightingChanges) {
  json j;
  j["particles"] = json::array({{{"procedural", {{"name", "random-spheres"}, {"count", 60}, {"radius", 0.08}, {"seed", 2}}}}});
  j["planes"] = json::array({{{"point", {0, -0.6, 0}}, {"normal", {0, 1, 0}}, {"size", 3}}});
  j["lights"] = json::array({{{"type", "directional"}, {"direction", {-0.3, -1, -0.2}}}});
  j["shadows"] = {{"technique", "issm"}, {"resolution", 64}};
  j["camera"] = {{"width", 48}, {"height", 40}};
  Engine engine(j, "");
  EXPECT_FALSE(engine.render().frame.surfaces_kept);
  auto after = [&](const std::string& path, const json& value, bool kept) {
    SCOPED_TRACE(path);
    engine.set(path, value);
    const EngineFrame f = engine.render();
    EXPECT_EQ(f.frame.surfaces_kept, kept);
    const Image fresh = Renderer(build_scene(engine.document(), "")).render().image;
    ASSERT_EQ(f.image.pixels().size(), fresh.pixels().size());
    EXPECT_EQ(std::memcmp(f.image.pixels().data(), fresh.pixels().data(), fresh.pixels().size() * sizeof(Rgb)), 0);
  };
  after("lights.0.direction", {0.4, -1, 0.1}, true);
  after("shadows.technique", "ray_traced", true);
  after("shading.ambient", 0.3, true);
  after("planes.0.color", {0.2, 0.9, 0.3}, false);
  after("lights.0.direction", {0.1, -1, 0.3}, true);
  after("particles.0.color_by", "uniform", false);
  after("planes.0.receives_shadows", false, false);
  after("camera.eye", {1.8, 1.2, 2.2}, false);
  after("lights.0.direction", {-0.2, -1, 0.3}, true);
  // a frame drawn from a renderer's own lights (penumbra render --light-orbit) keeps them too
  Renderer r(build_scene(engine.document(), ""));
  r.render();
  std::vector<Light> turned = r.scene().lights;
  turned[0].direction = normalize(Vec3{0.3f, -1, -0.4f});
  const FrameResult moved = r.render(r.scene().camera, turned);
  EXPECT_TRUE(moved.surfaces_kept);
  Scene lit = build_scene(engine.document(), "");
  lit.lights = turned;
  const Image fresh = Renderer(lit).render().image;
  EXPECT_EQ(std::memcmp(moved.image.pixels().data(), fresh.pixels().data(), fresh.pixels().size() * sizeof(Rgb)), 0);
}

// A refused edit names the path and what was expected, and leaves the engine's scene, document and
// image as they were.
TEST(Engine, RefusedEditsChangeNothing) {
  Engine engine(mixed_scene(), "");
  const Image before = engine.render().image;
  const json document = engine.document();
  auto refused = [&](const std::vector<std::pair<std::string, json>>& edits, const std::string& expect) {
    SCOPED_TRACE(edits.front().first);
    try {
      engine.edit(edits);
      ADD_FAILURE() << "edit accepted";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(expect), std::string::npos) << e.what();
    }
    EXPECT_EQ(engine.document(), document);
  };
  refused({{"camera.nonsense", 1}}, "camera.nonsense");
  refused({{"nonsense.path", 1}}, "nonsense.path: not a scene path");
  refused({{"lights.7.direction", {0, -1, 0}}}, "past the end");
  refused({{"camera.fov_deg", "wide"}}, "camera.fov_deg");
  refused({{"camera.fov_deg", 500}}, "camera.fov_deg");
  refused({{"isosurfaces.0.value", 50}}, "isosurfaces.0.value");
  refused({{"shadows.technique", "magic"}}, "shadows.technique");
  refused({{"shadows.spheres", "light_pass"}}, "shadows.spheres");
  // several edits at once: one bad one refuses them all
  refused({{"camera.fov_deg", 40}, {"volumes.0.step", -3}}, "volumes.0.step");
  EXPECT_TRUE(engine.render({Quality::Full, false}).rebuilt.empty());
  const Image after = engine.render({Quality::Full, false}).image;
  EXPECT_EQ(std::memcmp(before.pixels().data(), after.pixels().data(), before.pixels().size() * sizeof(Rgb)), 0);
}

namespace {

// A small cssm volume over a plane: noisy per seed, so accumulation has something to average.
json cssm_scene(int size = 32) {
  json j = volume_scene({{"name", "test-spheres"}, {"size", 24}}, {{"preset", "test-spheres"}, {"opacity_scale", 3}});
  j["planes"] = json::array({{{"point", {0, -0.6, 0}}, {"normal", {0, 1, 0}}, {"size", 3}}});
  j["shadows"] = {{"technique", "cssm"}, {"resolution", 48}};
  j["camera"] = {{"width", size}, {"height", size}};
  return j;
}

double mean_squared_difference(const std::vector<Rgb>& a, const std::vector<Rgb>& b) {
  double s = 0;
  for (std::size_t i = 0; i < a.size(); ++i)
    for (int c = 0; c < 3; ++c) s += std::pow(double(a[i][c]) - double(b[i][c]), 2);
  return s / (3.0 * static_cast<double>(a.size()));
}

}  // namespace

// Proves accumulation averages independent samples: the engine's image after k samples is the mean of
// the k sample frames, and its squared distance to the mean of all N falls as σ²(1/k − 1/N), with σ²
// each pixel's variance over the N samples — the 1/√k convergence of an unbiased estimator (new cssm
// seeds and new jitter each sample).
TEST(Engine, AccumulatedCssmConvergesLikeOneOverRootFrames) {
  Engine engine(cssm_scene(), "");
  constexpr int kSamples = 32;
  std::vector<std::vector<Rgb>> samples, means;
  for (int k = 0; k < kSamples; ++k) {
    const EngineFrame f = engine.render();
    ASSERT_EQ(f.samples, k + 1);
    samples.push_back(k == 0 ? f.image.pixels() : f.frame.image.pixels());  // the first sample is the image
    means.push_back(f.image.pixels());
    if (k > 0) {  // the only rebuild is the new seed's shadows
      ASSERT_EQ(f.rebuilt.size(), 1u);
      EXPECT_EQ(f.rebuilt.front().structure, "lights.0.shadows");
      EXPECT_EQ(f.rebuilt.front().cause, "sample");
    }
  }
  EXPECT_NE(samples[0], samples[1]) << "samples do not differ: nothing to accumulate";
  const std::size_t n = samples[0].size();
  std::vector<Rgb> mean(n, Rgb(0.0f));
  for (const auto& s : samples)
    for (std::size_t i = 0; i < n; ++i) mean[i] += s[i] * (1.0f / kSamples);
  double variance = 0;  // mean over pixels and channels of the per-pixel sample variance
  for (std::size_t i = 0; i < n; ++i)
    for (int c = 0; c < 3; ++c) {
      double v = 0;
      for (const auto& s : samples) v += std::pow(double(s[i][c]) - double(mean[i][c]), 2);
      variance += v / (kSamples - 1);
    }
  variance /= 3.0 * static_cast<double>(n);
  ASSERT_GT(variance, 1e-6);
  for (int k : {1, 2, 4, 8, 16}) {
    const double measured = mean_squared_difference(means[static_cast<std::size_t>(k - 1)], mean);
    const double expected = variance * (1.0 / k - 1.0 / kSamples);
    EXPECT_GT(measured / expected, 0.6) << k << " samples";
    EXPECT_LT(measured / expected, 1.6) << k << " samples";
  }
  // an edit starts again from one sample
  engine.set("lights.0.direction", {0.2, -1, 0.1});
  EXPECT_EQ(engine.render().samples, 1);
}

// Accumulated transparent output is the mean premultiplied frame, whatever the background: colour and
// coverage are averaged alike (a jittered cssm volume changes its coverage from sample to sample; with
// the last sample's alpha kept, the output moved with the background by about 0.03 after 8 samples).
TEST(Engine, AccumulatedTransparentOutputDoesNotDependOnTheBackground) {
  auto accumulate = [](const json& background, std::vector<float>& first_alpha) {
    json j = cssm_scene();
    j["background"] = background;
    Engine engine(j, "");
    std::vector<float> rgba(32 * 32 * 4);
    FrameBuffers buffers{rgba, {}, {}, true};
    FrameOptions options;
    options.buffers = &buffers;
    for (int k = 0; k < 8; ++k) {
      const EngineFrame f = engine.render(options);
      if (k == 0) first_alpha = f.frame.alpha;
      EXPECT_EQ(f.samples, k + 1);
    }
    return rgba;
  };
  std::vector<float> alpha_black, alpha_white;
  const std::vector<float> black = accumulate({0, 0, 0}, alpha_black);
  const std::vector<float> white = accumulate({1, 1, 1}, alpha_white);
  double coverage_change = 0, max_diff = 0;
  for (std::size_t i = 0; i < black.size(); ++i) {
    max_diff = std::max(max_diff, std::abs(double(black[i]) - double(white[i])));
    if (i % 4 == 3) coverage_change = std::max(coverage_change, std::abs(double(black[i]) - double(alpha_black[i / 4])));
  }
  EXPECT_GT(coverage_change, 0.01) << "the samples' coverage does not change: nothing to test";
  EXPECT_LT(max_diff, 1e-5) << "accumulated premultiplied RGBA depends on the background";
}

// Same samples for one and two threads, accumulation and an edit included.
TEST(Engine, AccumulationIsTheSameForAnyThreadCount) {
  auto run = [](int threads) {
    ThreadLimit limit(threads);
    Engine engine(mixed_scene(), "");
    for (int k = 0; k < 3; ++k) engine.render();
    engine.set("isosurfaces.0.value", 0.4);
    engine.render({Quality::Preview});
    engine.render();
    return engine.render().image.pixels();
  };
  const auto one = run(1), two = run(2);
  ASSERT_EQ(one.size(), two.size());
  EXPECT_EQ(std::memcmp(one.data(), two.data(), one.size() * sizeof(Rgb)), 0);
}

// A preview is smaller, rebuilds the edited structures coarser, and the next full frame refines them;
// a camera move's preview rebuilds nothing.
TEST(Engine, PreviewsRebuildCoarserAndFullFramesRefine) {
  json j = cssm_scene(48);
  j["shadows"]["resolution"] = 256;
  Engine engine(j, "");
  engine.render();
  engine.set("camera.direction", {1, 0.3, 0.5});
  const EngineFrame camera = engine.render({Quality::Preview});
  EXPECT_TRUE(camera.rebuilt.empty());
  EXPECT_GE(camera.divisor, 2);
  EXPECT_EQ(camera.image.width(), 48);
  engine.set("lights.0.direction", {0.3, -1, 0.2});
  const EngineFrame preview = engine.render({Quality::Preview});
  ASSERT_EQ(preview.rebuilt.size(), 1u);
  EXPECT_EQ(preview.rebuilt[0].structure, "lights.0.shadows");
  EXPECT_EQ(preview.rebuilt[0].cause, "lights.0.direction");
  const std::size_t preview_bytes = engine.renderer().shadow_memory_bytes();
  const EngineFrame full = engine.render();
  ASSERT_EQ(full.rebuilt.size(), 1u);
  EXPECT_EQ(full.rebuilt[0].structure, "lights.0.shadows");
  EXPECT_EQ(full.rebuilt[0].cause, "refine");
  EXPECT_LT(preview_bytes, engine.renderer().shadow_memory_bytes());  // coarser maps
  const Image fresh = Renderer(build_scene(engine.document(), "")).render().image;
  EXPECT_EQ(std::memcmp(full.image.pixels().data(), fresh.pixels().data(), fresh.pixels().size() * sizeof(Rgb)), 0);
}

// A preview asked not to be enlarged keeps its reduced size: each side 1/divisor of the camera's,
// rounded up, with the same pixels the enlarged preview repeats.
TEST(Engine, APreviewMayStayAtItsReducedSize) {
  Engine engine(cssm_scene(50), "");
  engine.render();
  engine.set("lights.0.direction", {0.3, -1, 0.2});
  FrameOptions small_options{Quality::Preview};
  small_options.enlarge_preview = false;
  const EngineFrame small = engine.render(small_options);
  const int d = small.divisor;
  ASSERT_GE(d, 2);
  EXPECT_EQ(small.image.width(), (50 + d - 1) / d);
  EXPECT_EQ(small.image.height(), (50 + d - 1) / d);
  const EngineFrame enlarged = engine.render({Quality::Preview});
  ASSERT_EQ(enlarged.divisor, d);
  ASSERT_EQ(enlarged.image.width(), 50);
  EXPECT_EQ(enlarged.image.at(49, 49), small.image.at(small.image.width() - 1, small.image.height() - 1));
  EXPECT_EQ(enlarged.image.at(0, 0), small.image.at(0, 0));
}

// Proves a frame in flight stops within one chunk of work of its flag being set, throws Cancelled, and
// leaves the engine able to render the right image. The flag is set from the ray caster's own progress
// (Progress::set_observer), once the first band of 16 rows is done, so no clock decides: after it, the
// tiles already in flight stop at their next row and no other tile starts, so at most one band a worker
// thread is reported done after the flag, and the frame ends far short of its last row.
TEST(Engine, CancelledFrameStopsWithinAChunkAndTheEngineRecovers) {
  constexpr int kSize = 96, kBand = 16;
  json j = cssm_scene(kSize);
  j["shadows"] = {{"technique", "ray_traced"}, {"light_angle", 5}, {"area_rays", 64}};
  j["ambient"] = {{"technique", "ray_traced_ao"}, {"rays", 16}};
  Engine engine(j, "");
  std::atomic<bool> cancel{false};
  std::atomic<std::size_t> done_at_flag{0}, done_last{0};
  Progress::set_observer([&](std::string_view label, std::size_t done, std::size_t) {
    if (label != "render") return;
    std::size_t seen = done_last.load();
    while (done > seen && !done_last.compare_exchange_weak(seen, done)) {}
    if (done >= kBand && !cancel.exchange(true)) done_at_flag = done;
  });
  bool cancelled = false;
  try {
    engine.render({Quality::Full, true, &cancel});
  } catch (const Cancelled&) {
    cancelled = true;
  }
  Progress::set_observer({});
  ASSERT_TRUE(cancel.load()) << "the ray caster reported no progress: the cancel point was never reached";
  ASSERT_TRUE(cancelled) << "the frame finished although its flag was set after " << done_at_flag << " rows";
  const auto workers = static_cast<std::size_t>(ThreadLimit::current_max());
  EXPECT_LE(done_last.load(), done_at_flag.load() + workers * kBand) << "rows went on being rendered after the flag";
  EXPECT_LT(done_last.load(), static_cast<std::size_t>(kSize)) << "every row was rendered";
  // a cancelled frame leaves nothing half-built: a smaller edited frame is still exact
  engine.edit({{"camera.width", 24}, {"camera.height", 24}, {"shadows.area_rays", 4}, {"ambient.rays", 4}});
  const EngineFrame f = engine.render();
  const Image fresh = Renderer(build_scene(engine.document(), "")).render().image;
  EXPECT_EQ(std::memcmp(f.image.pixels().data(), fresh.pixels().data(), fresh.pixels().size() * sizeof(Rgb)), 0);
}

// The caller's buffers: premultiplied linear RGBA (alpha 0 on the background when asked), 8-bit sRGB,
// and the depth of what each pixel shows.
TEST(Engine, FrameBuffersHoldPremultipliedColourSrgbAndDepth) {
  json j = cssm_scene(40);
  j["planes"][0]["size"] = 0.8;  // leaves background around it
  j["background"] = {0.2, 0.4, 0.6};
  Engine engine(j, "");
  const std::size_t n = 40 * 40;
  std::vector<float> rgba(4 * n), depth(n);
  std::vector<std::uint8_t> srgb(4 * n);
  FrameBuffers buffers{rgba, srgb, depth, true};
  FrameOptions options;
  options.buffers = &buffers;
  const EngineFrame f = engine.render(options);
  const Scene& s = engine.scene();
  const PrimaryRays rays(s.camera);
  int background = 0, plane = 0, volume = 0;
  for (int y = 0; y < 40; ++y)
    for (int x = 0; x < 40; ++x) {
      const std::size_t i = static_cast<std::size_t>(y) * 40 + static_cast<std::size_t>(x);
      const float a = rgba[4 * i + 3];
      // premultiplied over the background gives the image
      for (int c = 0; c < 3; ++c) EXPECT_NEAR(rgba[4 * i + c] + s.background[c] * (1 - a), f.image.at(x, y)[c], 1e-5f);
      const Ray r = rays.ray(x, y);
      const float t_plane = s.planes[0].intersect(r, 0, kInfinity);
      if (t_plane < kInfinity) {
        ++plane;
        EXPECT_EQ(a, 1.0f);
        EXPECT_LE(depth[i], t_plane * (1 + 1e-5f));  // the plane, or volume in front of it
      } else if (a == 0) {
        ++background;
        EXPECT_TRUE(std::isinf(depth[i]));
        EXPECT_EQ(srgb[4 * i + 3], 0);
      } else {
        ++volume;
        const std::uint8_t r8 = static_cast<std::uint8_t>(std::lround(linear_to_srgb(std::clamp(rgba[4 * i] / a, 0.0f, 1.0f)) * 255));
        EXPECT_NEAR(srgb[4 * i], r8, 1);
        EXPECT_NEAR(srgb[4 * i + 3], static_cast<double>(std::lround(a * 255)), 1);
      }
    }
  EXPECT_GT(background, 0);
  EXPECT_GT(plane, 0);
  EXPECT_GT(volume, 0);
  // a wrong size is refused before anything is written
  std::vector<float> small(3);
  FrameBuffers bad{small, {}, {}, false};
  options.buffers = &bad;
  EXPECT_THROW(engine.render(options), Error);
}

// Data the caller holds ("array" in the document, SceneArrays): a volume is a view of the caller's
// voxels, and replacing a particle array rebuilds the spheres and everything built from them, giving
// the image a fresh engine over the new spheres gives.
TEST(Engine, ReplacedArraysRebuildTheirObjectsAndMatchAFreshEngine) {
  auto voxels = std::make_shared<std::vector<float>>(12 * 10 * 8);
  for (std::size_t i = 0; i < voxels->size(); ++i) (*voxels)[i] = static_cast<float>((i * 7919) % 101) / 100.0f;
  auto spheres = [](float shift) {
    auto set = std::make_shared<ParticleSet>(random_spheres(40, 0.06f, 9));
    for (auto& s : set->spheres) s.center.y += shift;
    return std::shared_ptr<const ParticleSet>(std::move(set));
  };
  SceneArrays arrays;
  arrays.volumes["v"] = std::make_shared<const Volume>(
      Volume::view(ScalarType::Float32, {8, 10, 12}, reinterpret_cast<const std::byte*>(voxels->data()), voxels, {0.1f, 0.1f, 0.1f}));
  arrays.particles["p"] = spheres(0);
  json j;
  j["volumes"] = json::array({{{"array", "v"}, {"spacing", {0.12, 0.1, 0.08}}, {"origin", {-1.5, -0.5, -0.5}}, {"transfer_function", step_tf(0.5, 0.9, 0.5, 0.3)}}});
  j["particles"] = json::array({{{"array", "p"}}});
  j["shadows"] = {{"technique", "ray_traced"}};
  j["camera"] = {{"width", 32}, {"height", 28}};
  SceneReadOptions options;
  options.arrays = &arrays;
  Engine engine(j, "", options);
  EXPECT_EQ(engine.scene().volumes[0].volume->data(), reinterpret_cast<const std::byte*>(voxels->data()));  // not copied
  EXPECT_EQ(engine.scene().volumes[0].volume->spacing().x, 0.12f);  // the document's spacing
  engine.render();

  engine.replace_array("p", spheres(0.2f));
  const EngineFrame moved = engine.render();
  std::vector<std::string> rebuilt;
  for (const auto& r : moved.rebuilt) {
    rebuilt.push_back(r.structure);
    EXPECT_EQ(r.cause, "particles.0");
  }
  for (const char* s : {"spheres", "bvh", "casters"}) EXPECT_NE(std::find(rebuilt.begin(), rebuilt.end(), s), rebuilt.end()) << s;
  arrays.particles["p"] = spheres(0.2f);
  const Image fresh = Engine(j, "", options).render().image;
  EXPECT_EQ(std::memcmp(moved.image.pixels().data(), fresh.pixels().data(), fresh.pixels().size() * sizeof(Rgb)), 0);
  EXPECT_TRUE(non_trivial(fresh));

  EXPECT_THROW(engine.replace_array("nope", spheres(0)), Error);
  EXPECT_THROW(engine.replace_array("p", std::make_shared<const ParticleSet>()), Error);
  // a reader without arrays refuses the name
  try {
    Engine without(j, "");
    FAIL() << "an \"array\" without arrays was read";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("volumes.0.array"), std::string::npos) << e.what();
  }
}

TEST(Volume, AViewSharesTheVoxelsAndChecksThem) {
  auto voxels = std::make_shared<std::vector<std::uint16_t>>(4 * 3 * 2, std::uint16_t{7});
  (*voxels)[5] = 900;
  const Volume v = Volume::view(ScalarType::UInt16, {4, 3, 2}, reinterpret_cast<const std::byte*>(voxels->data()), voxels);
  EXPECT_TRUE(v.is_view());
  EXPECT_EQ(v.memory_bytes(), 0u);
  EXPECT_EQ(v.min_value(), 7.0f);
  EXPECT_EQ(v.max_value(), 900.0f);
  const Volume copy = v;  // a copy of a view shares the voxels
  EXPECT_EQ(copy.data(), v.data());
  EXPECT_EQ(voxels.use_count(), 3);
  Volume owned(ScalarType::UInt8, {2, 2, 2});
  const Volume owned_copy = owned;  // a copy of allocated voxels owns its own
  EXPECT_NE(owned_copy.data(), owned.data());
  auto nan = std::make_shared<std::vector<float>>(8, std::nanf(""));
  EXPECT_THROW(Volume::view(ScalarType::Float32, {2, 2, 2}, reinterpret_cast<const std::byte*>(nan->data()), nan), Error);
  EXPECT_THROW(Volume::view(ScalarType::Float32, {0, 2, 2}, reinterpret_cast<const std::byte*>(nan->data()), nan), Error);
}
