// Clip planes (scene key clip_planes, core/clip_planes.h): the closed forms of the plane queries, cut
// spheres against their geometry, and whole frames: a clipped volume renders exactly as the volume with
// the voxels beyond the plane set to zero — for the eye and for every light — in each technique against
// its own zeroed image, clipped spheres cast no shadow (ray-traced reference), isosurfaces end at the
// cut, and a plane edit rebuilds only what it cuts.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <memory>
#include <string>

#include "error_message.h"
#include "image_check.h"
#include "penumbra/core/clip_planes.h"
#include "penumbra/engine/invalidation.h"
#include "penumbra/geometry/cut_sphere.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene_io/scene_file.h"
#include "test_scenes.h"

namespace penumbra::test {
namespace {

using json = nlohmann::json;

TEST(ClipPlanes, KeepTheIntervalBehindEveryPlane) {
  const ClipPlanes planes({ClipPlane{{0, 0, 1}, {0, 0, 1}}, ClipPlane{{0, 0, -2}, {0, 0, -1}}});  // keeps -2 <= z <= 1
  float t0 = 0, t1 = 100;
  ASSERT_TRUE(planes.keep(Ray{{0, 0, 10}, {0, 0, -1}}, t0, t1));
  EXPECT_FLOAT_EQ(t0, 9);
  EXPECT_FLOAT_EQ(t1, 12);
  t0 = 0, t1 = 100;
  EXPECT_FALSE(planes.keep(Ray{{0, 0, 5}, {1, 0, 0}}, t0, t1));  // parallel, in the removed half
  t0 = 0, t1 = 100;
  EXPECT_TRUE(planes.keep(Ray{{0, 0, 0}, {1, 0, 0}}, t0, t1));  // parallel, kept all along
  EXPECT_EQ(t1, 100);
  EXPECT_TRUE(planes.removes({0, 0, 1.01f}));
  EXPECT_FALSE(planes.removes({0, 0, 0.99f}));
}

TEST(ClipPlanes, ClassifySpheresAndTheirKeptVolume) {
  const ClipPlanes planes({ClipPlane{{0, 0, 0}, {0, 0, 1}}});
  EXPECT_EQ(planes.classify({0, 0, -2}, 1), kSphereWhole);
  EXPECT_EQ(planes.classify({0, 0, 2}, 1), kSphereRemoved);
  EXPECT_EQ(planes.classify({0, 0, 0.5f}, 1), SphereClip{1});
  // a cap of height h keeps h²(3r − h) / (4r³) of the ball
  EXPECT_NEAR(planes.kept_fraction({0, 0, 0}, 1, 1), 0.5, 1e-6);
  EXPECT_NEAR(planes.kept_fraction({0, 0, -0.5f}, 1, 1), 1.5 * 1.5 * 1.5 / 4, 1e-6);
  EXPECT_NEAR(planes.kept_fraction({0, 0, 0.5f}, 1, 1), 0.5 * 0.5 * 2.5 / 4, 1e-6);
}

TEST(CutSphere, RaysMeetTheCapOrTheKeptSurface) {
  const ClipPlanes planes({ClipPlane{{0, 0, 0}, {0, 0, 1}}});  // removes z > 0
  const Sphere s{{0, 0, 0}, 1};
  // from above: through the removed half onto the cap at z = 0
  const Ray down{{0.3f, 0.2f, 5}, {0, 0, -1}};
  EXPECT_NEAR(intersect_cut_sphere(down, s, planes, 1, 0, kInfinity), 5, 1e-5);
  const Vec3 n = cut_sphere_normal(s, planes, 1, down.at(5));
  EXPECT_NEAR(n.z, 1, 1e-6);
  // from below: the sphere's own surface at z = -1
  const Ray up{{0, 0, -5}, {0, 0, 1}};
  EXPECT_NEAR(intersect_cut_sphere(up, s, planes, 1, 0, kInfinity), 4, 1e-5);
  EXPECT_NEAR(cut_sphere_normal(s, planes, 1, up.at(4)).z, -1, 1e-5);
  // a ray through the removed half only
  EXPECT_EQ(intersect_cut_sphere(Ray{{-5, 0, 0.5f}, {1, 0, 0}}, s, planes, 1, 0, kInfinity), kInfinity);
  // starting inside the kept part: it leaves through the cap
  EXPECT_NEAR(intersect_cut_sphere(Ray{{0, 0, -0.5f}, {0, 0, 1}}, s, planes, 1, 0, kInfinity), 0.5, 1e-6);
}

// Two blocks on a 24³ grid, more than two voxels from the plane x = 11.5 (voxels) between them.
std::shared_ptr<Volume> two_blocks(bool left, bool right) {
  const int n = 24;
  auto v = std::make_shared<Volume>(ScalarType::Float32, std::array<int, 3>{n, n, n},
                                    Vec3{1.0f / (n - 1), 1.0f / (n - 1), 1.0f / (n - 1)}, Vec3{-0.5f, -0.5f, -0.5f});
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x) {
        const bool in_left = x >= 3 && x <= 8 && y >= 5 && y <= 18 && z >= 5 && z <= 18;
        const bool in_right = x >= 15 && x <= 20 && y >= 3 && y <= 20 && z >= 3 && z <= 20;
        v->set_value(v->index(x, y, z), (left && in_left) || (right && in_right) ? 1.0f : 0.0f);
      }
  v->recompute_range();
  return v;
}

constexpr float kCutX = -0.5f + 11.5f / 23;  // world x of the plane between the blocks

// The blocks under a light from +x (the right block shadows the left one), with a floor.
json blocks_scene(const json& shadows, const json& ambient, bool clipped, const std::string& compositing) {
  json j;
  j["volumes"] = json::array({{{"array", "v"}, {"transfer_function", step_tf(0.35, 0.9, 0.5, 0.3)}, {"compositing", compositing}}});
  j["planes"] = json::array({{{"point", {0, -0.7, 0}}, {"normal", {0, 1, 0}}, {"size", 3}}});
  j["lights"] = json::array({{{"type", "directional"}, {"direction", {-1.0, -0.6, -0.2}}}});
  j["camera"] = {{"width", 48}, {"height", 48}, {"direction", {0.2, 0.5, 1.0}}};
  j["shadows"] = shadows;
  if (!ambient.is_null()) j["ambient"] = ambient;
  if (clipped) j["clip_planes"] = json::array({{{"point", {kCutX, 0, 0}}, {"normal", {1, 0, 0}}}});
  return j;
}

Image render_with(const json& j, std::shared_ptr<Volume> volume) {
  SceneArrays arrays;
  arrays.volumes["v"] = std::move(volume);
  SceneReadOptions options;
  options.arrays = &arrays;
  return Renderer(build_scene(j, "", options)).render().image;
}

struct Technique {
  const char* name;
  json shadows, ambient;
  const char* compositing;
};

TEST(ClippedVolume, RendersAsTheVolumeZeroedBeyondThePlaneInEveryTechnique) {
  const std::vector<Technique> techniques = {
      {"none", {{"technique", "none"}}, nullptr, "alpha"},
      {"ray_traced", {{"technique", "ray_traced"}}, nullptr, "alpha"},
      {"shadow_map", {{"technique", "shadow_map"}, {"resolution", 128}}, nullptr, "alpha"},
      {"deep_shadow_map", {{"technique", "deep_shadow_map"}, {"resolution", 64}}, nullptr, "alpha"},
      {"cssm", {{"technique", "cssm"}, {"resolution", 64}, {"seed", 3}}, nullptr, "alpha"},
      {"ray_traced_ao", {{"technique", "none"}}, {{"technique", "ray_traced_ao"}, {"rays", 8}}, "alpha"},
      {"sat_cone", {{"technique", "sat_cone"}}, nullptr, "extinction"},
      {"sat_shells", {{"technique", "none"}}, {{"technique", "sat_shells"}}, "extinction"},
  };
  const auto both = two_blocks(true, true), left = two_blocks(true, false);
  for (const Technique& t : techniques) {
    SCOPED_TRACE(t.name);
    FailureImages keep;
    const Image clipped = render_with(blocks_scene(t.shadows, t.ambient, true, t.compositing), both);
    const Image zeroed = render_with(blocks_scene(t.shadows, t.ambient, false, t.compositing), left);
    keep.add(t.name, clipped, zeroed);
    EXPECT_LT(max_difference(clipped, zeroed), 1e-5);
    // and the right block is there when nothing clips it (the comparison sees it)
    EXPECT_GT(max_difference(render_with(blocks_scene(t.shadows, t.ambient, false, t.compositing), both), zeroed), 0.05);
  }
}

// A large sphere above a small one on a floor, the light straight down: clipped away, the large sphere
// casts nothing, so the frame equals the one without it; cut in half, every technique of spheres agrees
// with the ray-traced reference.
json spheres_scene(const json& shadows, const json& clip, const std::string& rasterizer = "splat") {
  json j;
  j["particles"] = json::array({{{"array", "p"}}});
  j["planes"] = json::array({{{"point", {0, -1.2, 0}}, {"normal", {0, 1, 0}}, {"size", 6}}});
  j["lights"] = json::array({{{"type", "directional"}, {"direction", {0.15, -1.0, 0.1}}}});
  j["camera"] = {{"width", 64}, {"height", 64}, {"direction", {0.3, 0.6, 1.0}}, {"target", {0, 0, 0}}, {"distance", 5}};
  j["shadows"] = shadows;
  j["sphere_renderer"] = rasterizer;
  if (!clip.is_null()) j["clip_planes"] = clip;
  return j;
}

std::shared_ptr<ParticleSet> two_spheres(bool upper) {
  auto p = std::make_shared<ParticleSet>();
  p->spheres.push_back({{0, -0.8f, 0}, 0.3f});
  p->colors.push_back(pack_rgba8({0.8f, 0.3f, 0.2f}));
  if (upper) {
    p->spheres.push_back({{0, 0.6f, 0}, 0.6f});
    p->colors.push_back(pack_rgba8({0.2f, 0.5f, 0.8f}));
  }
  return p;
}

Image render_spheres(const json& j, std::shared_ptr<ParticleSet> set) {
  SceneArrays arrays;
  arrays.particles["p"] = std::move(set);
  SceneReadOptions options;
  options.arrays = &arrays;
  return Renderer(build_scene(j, "", options)).render().image;
}

TEST(ClippedSpheres, ASphereClippedAwayCastsNoShadow) {
  const json above = json::array({{{"point", {0, -0.1, 0}}, {"normal", {0, 1, 0}}}});  // removes y > -0.1
  for (const char* technique : {"ray_traced", "issm", "shadow_map"}) {
    SCOPED_TRACE(technique);
    FailureImages keep;
    const json shadows = {{"technique", technique}, {"resolution", 256}};
    const Image clipped = render_spheres(spheres_scene(shadows, above), two_spheres(true));
    const Image without = render_spheres(spheres_scene(shadows, nullptr), two_spheres(false));
    keep.add("clipped", clipped, without);
    EXPECT_LT(max_difference(clipped, without), 1e-5);
    EXPECT_GT(max_difference(render_spheres(spheres_scene(shadows, nullptr), two_spheres(true)), without), 0.05);
  }
}

TEST(ClippedSpheres, CutSpheresAgreeWithTheRayTracedReference) {
  // a plane through the upper sphere, tilted: half of it casts, and the camera sees its cap
  const json cut = json::array({{{"point", {0, 0.6, 0.1}}, {"normal", {0.3, 0.2, 1.0}}}});
  const Image reference = render_spheres(spheres_scene({{"technique", "ray_traced"}}, cut), two_spheres(true));
  const Image embree = render_spheres(spheres_scene({{"technique", "ray_traced"}}, cut, "embree"), two_spheres(true));
  const Image issm = render_spheres(spheres_scene({{"technique", "issm"}, {"resolution", 512}, {"rings", 2}}, cut), two_spheres(true));
  const Image whole = render_spheres(spheres_scene({{"technique", "ray_traced"}}, nullptr), two_spheres(true));
  FailureImages keep;
  keep.add("embree", embree, reference);
  keep.add("issm", issm, reference);
  EXPECT_GT(compare_images(embree, reference).psnr, 45);  // both rasterizers meet the same exact caps
  EXPECT_GT(compare_images(issm, reference).psnr, 30);
  EXPECT_LT(compare_images(whole, reference).psnr, 30);  // the cut shows
}

// An isosurface cut by a plane: every eye method ends the surface at the plane and shows what lies
// behind; the points and the mesh agree with the exact ray cast.
TEST(ClippedIsosurface, EveryMethodEndsAtThePlane) {
  auto scene_for = [&](const char* method, bool clipped) {
    json j = volume_scene({{"name", "sphere"}, {"size", 40}}, step_tf(0.5));
    j["volumes"][0]["visible"] = false;
    j["volumes"][0].erase("transfer_function");
    j["volumes"][0].erase("step");
    j["isosurfaces"] = json::array({{{"value", 0.5}, {"method", method}}});
    j["camera"] = {{"width", 64}, {"height", 64}, {"direction", {0.2, 0.3, 1.0}}};
    j["shadows"] = {{"technique", "ray_traced"}};
    if (clipped) j["clip_planes"] = json::array({{{"point", {0, 0, 0.05}}, {"normal", {0.1, 0.2, 1.0}}}});
    return Renderer(build_scene(j, "")).render().image;
  };
  const Image reference = scene_for("raycast", true);
  EXPECT_LT(compare_images(scene_for("raycast", false), reference).psnr, 25);
  FailureImages keep;
  for (const char* method : {"points", "mesh"}) {
    const Image image = scene_for(method, true);
    keep.add(method, image, reference);
    EXPECT_GT(compare_images(image, reference).psnr, 30) << method;
  }
}

TEST(ClipPlanesFile, BadPlanesAreErrorsNamingTheKey) {
  json j = volume_scene({{"name", "sphere"}, {"size", 8}}, step_tf(0.5));
  j["clip_planes"] = json::array({{{"point", {0, 0, 0}}, {"normal", {0, 0, 0}}}});
  EXPECT_NE(error_message([&] { build_scene(j, ""); }).find("clip_planes.0.normal"), std::string::npos);
  j["clip_planes"] = json::array({{{"point", {0, 0, 0}}}});
  EXPECT_NE(error_message([&] { build_scene(j, ""); }).find("clip_planes.0.normal"), std::string::npos);
  j["clip_planes"] = json::array();
  for (int i = 0; i < 7; ++i) j["clip_planes"].push_back({{"point", {0, 0, 0}}, {"normal", {0, 0, 1}}});
  EXPECT_NE(error_message([&] { build_scene(j, ""); }).find("at most 6"), std::string::npos);
  j["clip_planes"] = json::array({{{"point", {0, 0, 0}}, {"normal", {0, 0, 1}}, {"offset", 1}}});
  EXPECT_NE(error_message([&] { build_scene(j, ""); }).find("offset"), std::string::npos);
}

TEST(ClipPlanesFile, PlanesStayWholeUnlessAsked) {
  json j = volume_scene({{"name", "sphere"}, {"size", 8}}, step_tf(0.5));
  j["planes"] = json::array({{{"point", {0, -0.6, 0}}, {"normal", {0, 1, 0}}}, {{"point", {0, -0.7, 0}}, {"normal", {0, 1, 0}}, {"clip", true}}});
  j["clip_planes"] = json::array({{{"point", {0, 0, 0}}, {"normal", {1, 0, 0}}}});
  const Scene s = build_scene(j, "");
  EXPECT_TRUE(s.planes[0].clip_planes.empty());
  ASSERT_EQ(s.planes[1].clip_planes.size(), 1u);
  const Ray down{{0.5f, 1, 0}, {0, -1, 0}};  // onto the removed half of the planes
  EXPECT_LT(s.planes[0].intersect(down, 0, kInfinity), kInfinity);
  EXPECT_EQ(s.planes[1].intersect(down, 0, kInfinity), kInfinity);
}

// Moving a clip plane rebuilds what it cuts (the spheres' marks, the SAT, every light structure) and
// never the gradients or the min/max grids.
TEST(ClipPlanesEdit, RebuildsWhatItCutsAndNoGradients) {
  json j = blocks_scene({{"technique", "cssm"}, {"resolution", 64}}, nullptr, true, "alpha");
  SceneArrays arrays;
  arrays.volumes["v"] = two_blocks(true, true);
  SceneDataCache cache;  // as the engine reads edits: the data stays the same object
  SceneReadOptions options;
  options.arrays = &arrays;
  options.cache = &cache;
  Renderer r(build_scene(j, "", options));
  (void)r.render();
  j["clip_planes"][0]["point"] = {kCutX - 0.1, 0, 0};
  const Scene edited = build_scene(j, "", options);
  const std::vector<std::string> stale = invalidated_by("clip_planes", edited);
  r.apply_edit(edited, stale);
  const FrameResult f = r.render();
  auto rebuilt = [&](const std::string& n) { return std::find(f.rebuilt.begin(), f.rebuilt.end(), n) != f.rebuilt.end(); };
  EXPECT_TRUE(rebuilt("casters"));
  EXPECT_TRUE(rebuilt("lights.0.shadows"));
  EXPECT_FALSE(rebuilt("volumes.0.gradients"));
  EXPECT_FALSE(rebuilt("volumes.0.minmax"));
  EXPECT_FALSE(rebuilt("volumes.0.lut"));
  // and the frame is the one a fresh renderer draws
  EXPECT_LT(max_difference(f.image, Renderer(build_scene(j, "", options)).render().image), 1e-6);
}

}  // namespace
}  // namespace penumbra::test
