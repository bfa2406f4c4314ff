// Tests of the point-based isosurface (paper 002): the hierarchical visibility buffer against brute
// force, value pruning against a scan of every cell, visibility pruning against an unpruned
// extraction, points on the surface and their coverage against the ray-cast reference, light-pass
// shadows against exact shadow rays (and the tight frustum against the whole-volume one), hole
// punching (§4.2), determinism across thread counts, and the scene file's checks.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <functional>
#include <memory>
#include <set>
#include <string>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/geometry/grid_tree.h"
#include "penumbra/geometry/isosurface_raycaster.h"
#include "penumbra/isosurface/light_pass.h"
#include "penumbra/isosurface/point_extraction.h"
#include "penumbra/shadows/ray_traced.h"
#include "penumbra/isosurface/visibility_buffer.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene_io/scene_file.h"
#include "ball_volumes.h"
#include "image_check.h"
#include "isosurface_test_util.h"
#include "test_scenes.h"

using namespace penumbra;
using penumbra::test::field_volume;
using penumbra::test::sanitize_scale;

namespace {

float sphere_field(const Vec3& p, const Vec3& c, float r) { return r - length(p - c); }

// A sphere shell (radius 0.35, 0.08 thick) above a slab (|y + 0.6| <= 0.08): the known occluder.
float shell_over_slab(const Vec3& p) {
  const float shell = 0.04f - std::abs(length(p - Vec3{0, 0.25f, 0}) - 0.35f);
  const float slab = 0.08f - std::abs(p.y + 0.6f);
  return std::max(shell, slab);
}

// A noisy field with many small components: the hard case for pruning.
Volume noisy_volume(int n) {
  return field_volume(n, [](const Vec3& p) {
    const std::uint64_t h = (static_cast<std::uint64_t>((p.x + 2) * 1000) * 73856093u) ^
                            (static_cast<std::uint64_t>((p.y + 2) * 1000) * 19349663u) ^
                            (static_cast<std::uint64_t>((p.z + 2) * 1000) * 83492791u);
    return sphere_field(p, {0, 0, 0}, 0.6f) + 0.3f * (uniform_float(h, 0, 0) - 0.5f);
  });
}

Camera test_camera(int size, Vec3 eye = {1.6f, 1.1f, 2.3f}) { return test::camera_at(size, eye); }

bool same_points(const IsoPoints& a, const IsoPoints& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (a[i].pixel != b[i].pixel || a[i].distance != b[i].distance || a[i].position.x != b[i].position.x) return false;
  return true;
}

}  // namespace

TEST(VisibilityBuffer, QueriesMatchBruteForce) {
  const int w = 200, h = 77;  // not multiples of 8 or 64
  VisibilityBuffer vb(w, h, true);
  std::vector<std::uint8_t> brute(static_cast<std::size_t>(w * h), 1);
  for (int step = 0; step < 4000; ++step) {
    const int x = static_cast<int>(uniform_float(7, static_cast<std::uint64_t>(step), 0) * w);
    const int y = static_cast<int>(uniform_float(7, static_cast<std::uint64_t>(step), 1) * h);
    // mostly covering, sometimes punching holes back: every state of the hierarchy is visited
    if (uniform_float(7, static_cast<std::uint64_t>(step), 2) < 0.85f) {
      vb.set_covered(x, y);
      brute[static_cast<std::size_t>(y * w + x)] = 0;
    } else {
      vb.set_visible(x, y);
      brute[static_cast<std::size_t>(y * w + x)] = 1;
    }
    if (step % 20 != 0) continue;
    for (int q = 0; q < 20; ++q) {
      int x0 = static_cast<int>(uniform_float(9, static_cast<std::uint64_t>(step * 20 + q), 0) * (w + 20)) - 10;
      int y0 = static_cast<int>(uniform_float(9, static_cast<std::uint64_t>(step * 20 + q), 1) * (h + 20)) - 10;
      const int x1 = x0 + static_cast<int>(uniform_float(9, static_cast<std::uint64_t>(step * 20 + q), 2) * 90);
      const int y1 = y0 + static_cast<int>(uniform_float(9, static_cast<std::uint64_t>(step * 20 + q), 3) * 40);
      bool expected = false;
      for (int yy = std::max(y0, 0); yy <= std::min(y1, h - 1); ++yy)
        for (int xx = std::max(x0, 0); xx <= std::min(x1, w - 1); ++xx) expected |= brute[static_cast<std::size_t>(yy * w + xx)] != 0;
      ASSERT_EQ(vb.any_visible(x0, y0, x1, y1), expected) << x0 << "," << y0 << " " << x1 << "," << y1;
    }
  }
  std::size_t count = 0;
  for (auto b : brute) count += b;
  EXPECT_EQ(vb.visible_count(), count);
  VisibilityBuffer none(w, h, false);
  EXPECT_FALSE(none.any_visible(0, 0, w - 1, h - 1));
  none.set_visible(w - 1, h - 1);
  EXPECT_TRUE(none.any_visible(0, 0, w - 1, h - 1));
  EXPECT_FALSE(none.any_visible(0, 0, w - 2, h - 1));
}

TEST(GridTree, ValuePruningNeverDropsACellHoldingTheSurface) {
  const Volume v = noisy_volume(37);  // 36 cells: bricks do not divide it evenly
  const GridTree tree(v);
  EXPECT_EQ(tree.level_dims(tree.levels() - 1), (std::array<int, 3>{1, 1, 1}));
  for (float iso : {-0.3f, -0.05f, 0.0f, 0.1f, 0.5f}) {
    std::size_t straddling = 0;
    for (int k = 0; k < 36; ++k)
      for (int j = 0; j < 36; ++j)
        for (int i = 0; i < 36; ++i) {
          float lo = kInfinity, hi = -kInfinity;
          for (int c = 0; c < 8; ++c) {
            const float x = v.value(i + (c & 1), j + ((c >> 1) & 1), k + (c >> 2));
            lo = std::min(lo, x);
            hi = std::max(hi, x);
          }
          if (!range_straddles(lo, hi, iso)) continue;
          ++straddling;
          for (int l = 0; l < tree.levels(); ++l) {
            const int n = tree.node_cells(l);
            ASSERT_TRUE(tree.may_contain(l, i / n, j / n, k / n, iso)) << "level " << l << " cell " << i << "," << j << "," << k;
          }
        }
    EXPECT_GT(straddling, 0u);
  }
  // and prunes: a value above the maximum leaves nothing at the root
  EXPECT_FALSE(tree.may_contain(tree.levels() - 1, 0, 0, 0, v.max_value() + 1));
}

TEST(PointExtraction, VisibilityPruningDropsNothingVisible) {
  const Volume v = noisy_volume(sanitize_scale() ? 33 : 65);
  const GridTree tree(v);
  const ViewProjection view = ViewProjection::from_camera(test_camera(96));
  for (bool collapse : {false, true}) {
    ExtractionOptions pruned;
    pruned.collapse = collapse;
    ExtractionOptions unpruned = pruned;
    unpruned.visibility_pruning = false;
    const Extraction a = extract_points(tree, 0.0f, view, pruned);
    const Extraction b = extract_points(tree, 0.0f, view, unpruned);
    EXPECT_TRUE(same_points(a.points, b.points)) << "collapse " << collapse << ": " << a.points.size() << " vs " << b.points.size();
    EXPECT_GT(a.stats.visibility_pruned, 0u);
    EXPECT_LT(a.stats.nodes_visited, b.stats.nodes_visited);
  }
}

TEST(PointExtraction, PointsLieOnTheSurfaceAndCoverTheReference) {
  const int n = sanitize_scale() ? 33 : 65;
  const Vec3 centre{0.1f, -0.05f, 0.0f};
  const Volume v = field_volume(n, [&](const Vec3& p) { return sphere_field(p, centre, 0.55f); });
  const GridTree tree(v);
  const float cell = length(v.spacing());
  for (int size : {48, 160, 400}) {  // cells larger and smaller than a pixel
    SCOPED_TRACE(size);
    const Camera cam = test_camera(size);
    ExtractionOptions options;
    options.collapse = false;
    const Extraction e = extract_points(tree, 0.0f, ViewProjection::from_camera(cam), options);
    std::set<std::uint32_t> pixels;
    for (const IsoPoint& p : e.points) {
      ASSERT_LE(std::abs(length(p.position - centre) - 0.55f), cell) << "a point off the surface";
      ASSERT_TRUE(pixels.insert(p.pixel).second) << "two points on one pixel";
      const Vec3 outward = normalize(p.position - centre);
      ASSERT_GT(std::abs(dot(p.normal, outward)), 0.95f);
    }
    const IsosurfaceRaycaster ref(tree, 0.0f);
    const IsoPoints exact = ref.render(cam);
    std::size_t covered = 0;
    for (const IsoPoint& p : exact) covered += pixels.count(p.pixel);
    const double coverage = static_cast<double>(covered) / static_cast<double>(exact.size());
    EXPECT_GE(coverage, 0.97) << covered << " of " << exact.size();
    EXPECT_LE(e.points.size(), exact.size() + exact.size() / 20);  // no halo of extra pixels
  }
}

TEST(PointExtraction, SameForOneAndTwoThreads) {
  const Volume v = noisy_volume(49);
  const GridTree tree(v);
  const ViewProjection view = ViewProjection::from_camera(test_camera(130));
  Extraction a, b;
  {
    ThreadLimit l(1);
    a = extract_points(tree, 0.0f, view);
  }
  {
    ThreadLimit l(2);
    b = extract_points(tree, 0.0f, view);
  }
  EXPECT_TRUE(same_points(a.points, b.points));
  EXPECT_GT(a.points.size(), 1000u);
}

TEST(ViewProjection, FromCameraMatchesPrimaryRays) {
  const Camera cam = test_camera(64);
  const ViewProjection view = ViewProjection::from_camera(cam);
  const PrimaryRays rays(cam);
  for (int y = 0; y < 64; y += 9)
    for (int x = 0; x < 64; x += 7) {
      const Ray r = rays.ray(x, y);
      const Ray q = view.ray(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f);
      EXPECT_LT(length(r.direction - q.direction), 1e-5f);
      float px, py;
      ASSERT_TRUE(view.project(r.at(3.0f), px, py));
      EXPECT_NEAR(px, static_cast<float>(x) + 0.5f, 1e-3f);
      EXPECT_NEAR(py, static_cast<float>(y) + 0.5f, 1e-3f);
    }
}

namespace {

// Agreement of light-pass shadows with exact shadow rays over the lit-facing eye points.
struct ShadowAgreement {
  double agreement;
  std::size_t eye_points, light_points, holes, shadowed;
};

ShadowAgreement light_pass_agreement(const GridTree& tree, const Camera& cam, const Light& light, LightPassSettings s) {
  ExtractionOptions options;
  const Extraction eye = extract_points(tree, 0.0f, ViewProjection::from_camera(cam), options);
  // the isosurface alone as the caster, the eye points as the receivers
  const IsosurfaceRaycaster raycaster(tree, 0.0f);
  ShadowCasters casters(Scene{}, {});
  casters.add_isosurface(raycaster, tree, 0);
  std::vector<SurfacePoint> receivers;
  for (const IsoPoint& p : eye.points) {
    SurfacePoint sp;
    sp.position = p.position;
    sp.normal = p.normal;
    sp.kind = ObjectKind::Isosurface;
    sp.error = p.error;
    receivers.push_back(sp);
  }
  LightPass pass(s);
  pass.build(casters, light);
  pass.fit_to_receivers(receivers, false, false);
  RayTracedShadows exact;
  exact.build(casters, light);
  std::vector<Rgb> a_rgb(receivers.size()), b_rgb(receivers.size());
  pass.transmittance(std::span<const SurfacePoint>(receivers), std::span<Rgb>(a_rgb));
  exact.transmittance(std::span<const SurfacePoint>(receivers), std::span<Rgb>(b_rgb));
  std::vector<float> a, b;
  for (std::size_t i = 0; i < receivers.size(); ++i) {
    a.push_back(a_rgb[i].r);
    b.push_back(b_rgb[i].r);
  }
  std::size_t facing = 0, agree = 0, shadowed = 0;
  for (std::size_t i = 0; i < eye.points.size(); ++i) {
    Vec3 to_light;
    float d;
    light.towards(eye.points[i].position, to_light, d);
    if (dot(eye.points[i].normal, to_light) <= 0) continue;  // unlit either way
    ++facing;
    agree += a[i] == b[i];
    shadowed += b[i] == 0;
  }
  return {static_cast<double>(agree) / static_cast<double>(facing), eye.points.size(),
          pass.passes().front().light_points.points.size(), pass.passes().front().hole_count, shadowed};
}

}  // namespace

TEST(LightPass, AgreesWithExactShadowRaysOnAKnownOccluder) {
  const Volume v = field_volume(sanitize_scale() ? 49 : 81, shell_over_slab);
  const GridTree tree(v);
  const Camera cam = test_camera(sanitize_scale() ? 96 : 192, {0.4f, 1.6f, 2.4f});
  Light light;
  light.type = LightType::Point;
  light.position = {0.6f, 2.5f, 0.3f};
  const ShadowAgreement tight = light_pass_agreement(tree, cam, light, {cam.width, LightFrustum::Tight, -1});
  EXPECT_GT(tight.shadowed, tight.eye_points / 20) << "the shell must shadow part of the slab";
  EXPECT_GE(tight.agreement, 0.97);
  // §4.2: holes only where eye points are, and at most one light point per hole.
  EXPECT_LE(tight.holes, tight.eye_points);
  EXPECT_LE(tight.light_points, tight.holes);
  // §4.3: at a coarse light buffer the fitted frustum samples the receivers better than the volume's.
  const int coarse = 48;
  const ShadowAgreement fitted = light_pass_agreement(tree, cam, light, {coarse, LightFrustum::Tight, -1});
  const ShadowAgreement whole = light_pass_agreement(tree, cam, light, {coarse, LightFrustum::Volume, -1});
  EXPECT_GT(fitted.agreement, whole.agreement);
  // A directional light (orthographic light view) as well.
  Light sun;
  sun.direction = normalize(Vec3{-0.3f, -1, -0.2f});
  EXPECT_GE(light_pass_agreement(tree, cam, sun, {cam.width, LightFrustum::Tight, -1}).agreement, 0.97);
}

// A close view of a voxelised ball (a binary field: its trilinear surface is terraced, with creases
// between the terraces): the point of a light pixel may lie on a steeper facet than the receivers
// under it, farther from the light than the receiver's own slope allows. Without the bias's crease
// share (a tenth of a voxel) those receivers were shadowed in dotted rows (1.6–2.0 % of the lit
// receivers here, at either light resolution); with it the light pass agrees with exact shadow rays.
TEST(LightPass, NoAcneOnTheCreasesOfAVoxelisedSurface) {
  Volume ball = test::ball_volume(64);
  for (std::size_t n = 0; n < ball.voxel_count(); ++n) ball.set_value(n, ball.value(n) - 0.75f);  // the surface at 0
  ball.recompute_range();
  const GridTree tree(ball);
  Camera cam;
  cam.eye = {-0.12f, 0.15f, 0.8f};
  cam.target = {-0.22f, 0.12f, 0.1f};
  cam.fov_deg = 15;
  cam.width = cam.height = sanitize_scale() ? 64 : 128;
  Light sun;
  sun.direction = normalize(Vec3{0.6f, -1.0f, -0.3f});
  for (int resolution : {256, 1024}) {
    SCOPED_TRACE(resolution);
    const ShadowAgreement a = light_pass_agreement(tree, cam, sun, {resolution, LightFrustum::Tight, -1});
    EXPECT_GE(a.agreement, 0.999) << a.eye_points << " eye points, " << a.shadowed << " shadowed by the rays";
  }
}

// A refined box's surface (CastingIsosurface::finer): a receiver inside the box, against a light pixel
// whose point lies on the box's finer surface, is biased for creases by a tenth of the box's voxel,
// not of the opened level's (which would lose contact shadows up to 2^levels finer there); a receiver
// outside the box keeps the opened level's.
TEST(LightPass, ARefinedBoxIsBiasedForCreasesByItsOwnVoxel) {
  // the ball |p| < 0.3 as the field 0.3 − |p|, sampled at 16³ over the cube and at 4× as fine over its upper half
  auto ball = [](std::array<int, 3> dims, Vec3 spacing, Vec3 origin) {
    Volume v(ScalarType::Float32, dims, spacing, origin);
    std::size_t n = 0;
    for (int k = 0; k < dims[2]; ++k)
      for (int j = 0; j < dims[1]; ++j)
        for (int i = 0; i < dims[0]; ++i)
          v.set_value(n++, 0.3f - length(origin + spacing * Vec3{static_cast<float>(i), static_cast<float>(j), static_cast<float>(k)}));
    v.recompute_range();
    return v;
  };
  const float h = 1.0f / 15.0f;
  const Volume coarse = ball({16, 16, 16}, {h, h, h}, {-0.5f, -0.5f, -0.5f});
  const Volume fine = ball({61, 61, 31}, {h / 4, h / 4, h / 4}, {-0.5f, -0.5f, 0.0f});
  const GridTree coarse_tree(coarse), fine_tree(fine);
  const IsosurfaceRaycaster coarse_rays(coarse_tree, 0.0f), fine_rays(fine_tree, 0.0f);
  ShadowCasters casters(Scene{}, {});
  casters.add_isosurface(coarse_rays, coarse_tree, 0, ClipPlanes(), CastingIsosurface::Finer{&fine_rays, &fine_tree});
  Light light;  // from +x: the lit side lies on both sides of the box's face z = 0
  light.direction = normalize(Vec3{-1.0f, -0.2f, -0.15f});
  std::vector<SurfacePoint> receivers;  // the lit side of the ball, on both sides of z = 0
  for (int a = 0; a < 40; ++a)
    for (int b = 0; b < 80; ++b) {
      const float theta = 3.1416f * (static_cast<float>(a) + 0.5f) / 40.0f, phi = 6.2832f * static_cast<float>(b) / 80.0f;
      const Vec3 n{std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta)};
      if (dot(n, -light.direction) < 0.3f) continue;
      SurfacePoint sp;
      sp.position = n * 0.3f;
      sp.normal = n;
      sp.kind = ObjectKind::Isosurface;
      receivers.push_back(sp);
    }
  LightPass pass({256, LightFrustum::Tight, -1});
  pass.build(casters, light);
  pass.fit_to_receivers(receivers, false, true);
  ASSERT_EQ(pass.passes().size(), 1u);
  const IsosurfaceLightPass& lp = pass.passes().front();
  EXPECT_FLOAT_EQ(lp.crease, 2 * isosurface_offset(coarse.spacing()));
  EXPECT_FLOAT_EQ(lp.finer_crease, 2 * isosurface_offset(fine.spacing()));
  std::size_t inside = 0, outside = 0;
  for (const SurfacePoint& r : receivers) {
    float px, py;
    ASSERT_TRUE(lp.view.project(r.position, px, py));
    const std::size_t k = static_cast<std::size_t>(std::floor(py)) * static_cast<std::size_t>(lp.view.width) + static_cast<std::size_t>(std::floor(px));
    if (lp.depth[k] == kInfinity) continue;
    if (r.position.z > 0.05f) {
      ++inside;
      EXPECT_FLOAT_EQ(lp.crease_at(k, r.position), lp.finer_crease) << "inside the box at z " << r.position.z;
    } else if (r.position.z < -0.05f) {
      ++outside;
      EXPECT_FLOAT_EQ(lp.crease_at(k, r.position), lp.crease) << "outside the box at z " << r.position.z;
    }
  }
  EXPECT_GT(inside, 100u);
  EXPECT_GT(outside, 20u);
  // and the box's receivers are all lit, as exact rays find them (the ball shadows none of its lit side)
  std::vector<Rgb> light_of(receivers.size());
  pass.transmittance(std::span<const SurfacePoint>(receivers), std::span<Rgb>(light_of));
  for (std::size_t i = 0; i < receivers.size(); ++i) {
    if (receivers[i].position.z > 0.05f) {
      EXPECT_EQ(light_of[i].r, 1.0f) << "acne at z " << receivers[i].position.z;
    }
  }
}

TEST(LightPass, TightFrustumHoldsEveryReceiver) {
  const Volume v = field_volume(41, shell_over_slab);
  const GridTree tree(v);
  const Extraction eye = extract_points(tree, 0.0f, ViewProjection::from_camera(test_camera(80)));
  Light light;
  light.type = LightType::Point;
  light.position = {3, 4, 1};
  const ViewProjection lv = fit_light_view(light, eye.points, v.bounds(), {64, LightFrustum::Tight, -1});
  const ViewProjection whole = fit_light_view(light, eye.points, v.bounds(), {64, LightFrustum::Volume, -1});
  float xmin = kInfinity, xmax = -kInfinity;
  for (const IsoPoint& p : eye.points) {
    float px, py;
    ASSERT_TRUE(lv.project(p.position, px, py));
    ASSERT_GE(px, 0);
    ASSERT_LT(px, 64);
    ASSERT_GE(py, 0);
    ASSERT_LT(py, 64);
    xmin = std::min(xmin, px);
    xmax = std::max(xmax, px);
  }
  EXPECT_GT(xmax - xmin, 60);  // the receivers fill the buffer
  EXPECT_LT((lv.right - lv.left) * (lv.top - lv.bottom), (whole.right - whole.left) * (whole.top - whole.bottom));
}

namespace {

nlohmann::json iso_scene() {
  return nlohmann::json::parse(R"({
    "volumes": [{"procedural": {"name": "hollow-sphere", "size": 24}, "visible": false}],
    "isosurfaces": [{"value": 0.5}],
    "lights": [{"type": "point", "position": [1, 2, 1]}],
    "shadows": {"technique": "light_pass"},
    "camera": {"width": 48, "height": 48}
  })");
}

void expect_scene_error(const nlohmann::json& j, const std::vector<std::string>& needles) {
  try {
    (void)build_scene(j, "");
    ADD_FAILURE() << "no error for " << j.dump();
  } catch (const Error& e) {
    for (const auto& n : needles) EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << n << " in: " << e.what();
  }
}

}  // namespace

TEST(IsosurfaceScene, RendersEveryMethodAndRejectsBadInput) {
  for (const char* method : {"points", "raycast", "mesh"}) {
    nlohmann::json j = iso_scene();
    j["isosurfaces"][0]["method"] = method;
    Renderer r(build_scene(j, ""));
    const FrameResult f = r.render();
    EXPECT_GT(f.isosurface.points, 200u) << method;
  }
  auto with = [](const std::string& key, const nlohmann::json& value) {
    nlohmann::json j = iso_scene();
    apply_override(j, key, value.dump());
    return j;
  };
  expect_scene_error(with("isosurfaces.0.value", 1.5), {"isosurfaces.0.value", "1.5", "outside the data range"});
  expect_scene_error(with("isosurfaces.0.value", 0.0), {"isosurfaces.0.value", "outside the data range"});
  expect_scene_error(with("isosurfaces.0.value", "NaN"), {"isosurfaces.0.value"});
  expect_scene_error(with("isosurfaces.0.volume", 3), {"isosurfaces.0.volume", "3", "1 volume"});
  expect_scene_error(with("isosurfaces.0.method", "marching"), {"isosurfaces.0.method", "marching", "points, raycast or mesh"});
  expect_scene_error(with("shadows.technique", "issm"), {"shadows", "issm", "is for spheres", "casters are isosurfaces"});
  expect_scene_error(with("shadows.isosurfaces", "sat_cone_x"), {"shadows.isosurfaces", "sat_cone_x", "light_pass"});
  expect_scene_error(with("isosurfaces.0.casts_shadows", "yes"), {"isosurfaces.0.casts_shadows"});
  expect_scene_error(with("shadows.light_frustum", "loose"), {"light_frustum", "loose", "tight"});
  nlohmann::json empty = iso_scene();
  empty["volumes"][0]["procedural"] = {{"name", "slab"}, {"size", 8}, {"thickness", 4.0}};  // every voxel 1
  expect_scene_error(empty, {"isosurfaces.0.volume", "constant"});
  // NaN voxels: the volume is refused where it is read, naming the file and the voxel.
  test::ScratchDir dir;
  {
    std::ofstream raw(dir.file("nan.raw"), std::ios::binary);
    const float voxels[8] = {0, 1, std::nanf(""), 1, 0, 1, 1, 0};
    raw.write(reinterpret_cast<const char*>(voxels), sizeof voxels);
  }
  nlohmann::json nan_scene = iso_scene();
  nan_scene["volumes"][0] = {{"file", dir.file("nan.raw")},
                             {"raw", {{"dims", {2, 2, 2}}, {"type", "float32"}}},
                             {"visible", false}};
  expect_scene_error(nan_scene, {"volumes.0.file", "nan.raw", "NaN"});
}

// Two isosurfaces of two volumes: nested spheres, the outer one cut open towards the camera and the
// light. The inner sphere shows through the cut, the outer shell shadows the inner one where the cut
// does not let the light in, and the result agrees with exact shadow rays through both surfaces.
TEST(IsosurfaceScene, SeveralIsosurfacesDrawAndShadowEachOther) {
  const int n = sanitize_scale() ? 41 : 65;
  // the inner sphere (r 0.3) in one volume, the outer shell (0.55 … 0.65, open where z > 0.25) in another
  Scene s;
  for (int v = 0; v < 2; ++v) {
    VolumeObject vo;
    vo.volume = std::make_shared<Volume>(field_volume(n, [v](const Vec3& p) {
      const float r = length(p);
      if (v == 0) return r < 0.3f ? 1.0f : 0.0f;
      return r > 0.55f && r < 0.65f && p.z < 0.25f ? 1.0f : 0.0f;
    }));
    vo.visible = false;
    s.volumes.push_back(vo);
  }
  s.isosurfaces.push_back([] { IsosurfaceObject o; o.volume = 0; o.value = 0.5f; o.color = {1, 0, 0}; return o; }());  // inner, red
  s.isosurfaces.push_back([] { IsosurfaceObject o; o.volume = 1; o.value = 0.5f; o.color = {0, 0, 1}; return o; }());  // shell, blue
  s.camera = test_camera(96, {0.4f, 0.3f, 2.4f});
  Light light;
  light.type = LightType::Point;
  light.position = {1.5f, 1.8f, 0.4f};  // beside the cut: the shell shadows much of the inner sphere
  s.lights.push_back(light);
  s.shadows.technique = "light_pass";
  s.shadows.params.set("resolution", 256);
  Renderer points(s);
  const FrameResult a = points.render();
  ASSERT_EQ(points.light_shadows().size(), 1u);
  ASSERT_EQ(points.light_shadows().front()->techniques().size(), 1u);  // one light pass for both isosurfaces
  EXPECT_EQ(dynamic_cast<const LightPass&>(*points.light_shadows().front()->techniques().front()).passes().size(), 2u);
  // the inner sphere is seen through the cut: red pixels
  std::size_t red = 0;
  for (int y = 0; y < 96; ++y)
    for (int x = 0; x < 96; ++x) red += a.image.at(x, y).r > 2 * a.image.at(x, y).b;
  EXPECT_GT(red, 200u);
  Scene exact_scene = s;
  for (auto& iso : exact_scene.isosurfaces) iso.method = IsosurfaceMethod::Raycast;
  exact_scene.shadows.technique = "ray_traced";
  Renderer exact(exact_scene);
  const FrameResult b = exact.render();
  test::FailureImages keep;
  keep.add("points_light_pass", a.image, b.image);
  std::size_t differ = 0, lit_ref = 0, covered = 0;
  for (int y = 0; y < 96; ++y)
    for (int x = 0; x < 96; ++x) {
      const Rgb p = a.image.at(x, y), q = b.image.at(x, y);
      if (q == s.background) continue;
      ++covered;
      lit_ref += std::max({q.r, q.g, q.b}) > 0.35f;
      differ += std::abs(std::max({p.r, p.g, p.b}) - std::max({q.r, q.g, q.b})) > 0.25f;
    }
  EXPECT_GT(lit_ref, covered / 10);
  EXPECT_LT(lit_ref, covered * 9 / 10) << "the scene must have both lit and shadowed parts";
  EXPECT_LT(static_cast<double>(differ), 0.05 * static_cast<double>(covered));
  // The shell casts onto the inner sphere: where the sphere shows in both frames, far more of it is
  // lit without the shell.
  Scene alone = s;
  alone.isosurfaces.pop_back();
  Renderer inner_only(alone);
  const Image c = inner_only.render().image;
  keep.add("without_shell", c, a.image);
  auto is_red = [](const Rgb& p) { return p.r > 2 * p.b && p.r > 0.05f; };
  std::size_t lit_with = 0, lit_without = 0;
  for (int y = 0; y < 96; ++y)
    for (int x = 0; x < 96; ++x)
      if (is_red(a.image.at(x, y)) && is_red(c.at(x, y))) {
        lit_with += a.image.at(x, y).r > 0.5f;
        lit_without += c.at(x, y).r > 0.5f;
      }
  EXPECT_GT(lit_without, lit_with * 3 / 2);  // 292 vs 137 when written; equal if the shell cast nothing
}

// Planes with an isosurface: a floor under a sphere receives its light-pass shadow where exact shadow
// rays put it, and a wall in front of the sphere hides it (depth-correct composition).
TEST(IsosurfaceScene, PlanesAreDepthCorrectAndReceiveTheShadow) {
  nlohmann::json j = nlohmann::json::parse(R"({
    "volumes": [{"procedural": {"name": "sphere", "size": 32, "radius": 0.3}, "visible": false}],
    "isosurfaces": [{"value": 0.5, "color": [1, 0, 0]}],
    "planes": [{"point": [0, -0.5, 0], "normal": [0, 1, 0], "size": 3, "color": [0.8, 0.8, 0.8]}],
    "lights": [{"type": "point", "position": [0.3, 2.0, 0.2]}],
    "shadows": {"technique": "light_pass", "resolution": 256},
    "camera": {"eye": [0, 0.9, 2.2], "target": [0, -0.2, 0], "width": 96, "height": 96}
  })");
  Renderer points(build_scene(j, ""));
  const Image a = points.render().image;
  nlohmann::json exact_json = j;
  exact_json["isosurfaces"][0]["method"] = "raycast";
  exact_json["shadows"]["technique"] = "ray_traced";
  Renderer exact(build_scene(exact_json, ""));
  const Image b = exact.render().image;
  test::FailureImages keep;
  keep.add("light_pass", a, b);
  auto floor = [](const Rgb& p) { return std::abs(p.r - p.g) < 0.02f && p.r > 0.05f; };  // grey, not the red sphere
  std::size_t floor_pixels = 0, shadowed = 0, differ = 0;
  for (int y = 0; y < 96; ++y)
    for (int x = 0; x < 96; ++x) {
      const Rgb p = a.at(x, y), q = b.at(x, y);
      if (!floor(p) || !floor(q)) continue;
      ++floor_pixels;
      const bool dark_p = p.r < 0.3f, dark_q = q.r < 0.3f;
      shadowed += dark_q;
      differ += dark_p != dark_q;
    }
  EXPECT_GT(floor_pixels, 2000u);
  EXPECT_GT(shadowed, 100u) << "the sphere must shadow the floor";
  // An image without shadows would differ on every shadowed floor pixel: the bound must fail it.
  EXPECT_GT(static_cast<double>(shadowed), 2 * 0.03 * static_cast<double>(floor_pixels));
  std::printf("[ floor    ] %zu floor pixels, %zu shadowed, %zu differ\n", floor_pixels, shadowed, differ);
  EXPECT_LT(static_cast<double>(differ), 0.03 * static_cast<double>(floor_pixels));
  // A wall between the camera and the sphere: no red pixel is left.
  j["planes"].push_back({{"point", {0, 0, 0.6}}, {"normal", {0, 0, 1}}, {"size", 3}, {"color", {0.2, 0.8, 0.2}}});
  Renderer walled(build_scene(j, ""));
  const Image c = walled.render().image;
  std::size_t red = 0;
  for (int y = 0; y < 96; ++y)
    for (int x = 0; x < 96; ++x) red += c.at(x, y).r > 2 * c.at(x, y).g;
  EXPECT_EQ(red, 0u);
}
