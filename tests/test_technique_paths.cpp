// Paths that had no test of their own (issue 12 §2): the classic shadow map's percentage-closer filter
// (`shadows.pcf`), soft shadows of a round light on spheres (`ray_traced` with `light_angle`) against a
// closed form, and the Embree sphere renderer (`sphere_renderer: embree`) through the Renderer. Each
// check fails when the path does nothing (pcf ignored, light_angle ignored, no spheres drawn).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstdio>
#include <set>
#include <vector>

#include "penumbra/registry/technique_catalog.h"
#include "penumbra/shadows/ray_traced.h"
#include "penumbra/geometry/sphere_bvh.h"
#include "penumbra/particles/sphere_hits.h"
#include "penumbra/render/renderer.h"
#include "penumbra/registry/registry.h"
#include "penumbra/shadows/shadow_map.h"
#include "image_check.h"
#include "test_scenes.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

// ---------------------------------------------------------------------------------------------------
// shadows.pcf

// An opaque ball (radius 0.3, opacity 0.6 per voxel: the accumulated opacity passes 0.5 within a voxel
// of its surface) under a light straight down, with the classic map's `pcf` given in the scene file.
nlohmann::json ball_scene(int pcf) {
  nlohmann::json j = volume_scene({{"name", "sphere"}, {"size", 48}, {"radius", 0.3}}, step_tf(0.6));
  j["shadows"] = {{"technique", "shadow_map"}, {"resolution", 96}, {"pcf", pcf}};
  return j;
}

// Percentage-closer filtering with radius r over (2r + 1)² texels: for a receiver at a texel centre, the
// filtered light is exactly the mean of the unfiltered map's answers at the (2r + 1)² receivers moved
// by whole texels across the light's view (same light depth, so the same biased depth is compared),
// hence a multiple of 1/(2r + 1)². Receivers on a texel row under the ball, crossing the shadow's edge:
// the unfiltered map switches once from 0 to 1 there, the filtered one ramps through fractional values
// over 2r + 1 texels. The settings reach the technique through the scene file (`shadows.pcf`). Equality
// is exact (1e-6 for the float division): both sides compare the same floats.
TEST(ShadowsPcf, FilteredLightIsTheMeanOfTheUnfilteredMapOverTheWindow) {
  for (const int r : {1, 2}) {
    SCOPED_TRACE("pcf " + std::to_string(r));
    MediumHolder filtered_m(ball_scene(r)), plain_m(ball_scene(0));
    ASSERT_EQ(static_cast<int>(param_integer(TechniqueFamily::Shadow, filtered_m.scene.shadows.params, "pcf")), r) << "the scene file's shadows.pcf";
    const Light light = filtered_m.scene.lights.at(0);
    auto filtered = make_shadow_technique(filtered_m.scene.shadows);
    filtered->build(*filtered_m.medium, light);
    auto plain = make_shadow_technique(plain_m.scene.shadows);
    plain->build(*plain_m.medium, light);
    const auto& proj = dynamic_cast<const ClassicShadowMap&>(*plain).projection();
    const int n = static_cast<int>(param_integer(TechniqueFamily::Shadow, plain_m.scene.shadows.params, "resolution"));
    const float fn = static_cast<float>(n);
    float u0, v0, d0;
    ASSERT_TRUE(proj.project({0, -0.42f, 0}, u0, v0, d0));  // under the ball, inside the box
    const int row = static_cast<int>(v0 * fn), first = static_cast<int>(u0 * fn);
    const float window = static_cast<float>((2 * r + 1) * (2 * r + 1));
    std::set<int> fractional;  // the k of the values k/(2r+1)² strictly between 0 and 1
    int switches = 0;
    float previous_plain = -1;
    for (int ix = first; ix < n - r - 1; ++ix) {
      auto at = [&](int x, int y) { return proj.texel_ray((static_cast<float>(x) + 0.5f) / fn, (static_cast<float>(y) + 0.5f) / fn).at(d0); };
      const float f = filtered->transmittance(at(ix, row)).r;
      float sum = 0;
      for (int dy = -r; dy <= r; ++dy)
        for (int dx = -r; dx <= r; ++dx) sum += plain->transmittance(at(ix + dx, row + dy)).r;
      EXPECT_NEAR(f, sum / window, 1e-6f) << "texel " << ix;
      const float k = f * window;
      EXPECT_NEAR(k, std::round(k), 1e-4f) << "texel " << ix << ": not a multiple of 1/(2r+1)²";
      if (f > 0 && f < 1) fractional.insert(static_cast<int>(std::lround(k)));
      const float p = plain->transmittance(at(ix, row)).r;
      EXPECT_TRUE(p == 0.0f || p == 1.0f);
      if (previous_plain >= 0 && p != previous_plain) ++switches;
      previous_plain = p;
    }
    std::printf("[ pcf      ] r = %d: %zu distinct fractional values across the edge\n", r, fractional.size());
    EXPECT_EQ(switches, 1) << "the unfiltered row crosses the shadow's edge once";
    // Across an edge perpendicular to the row (the ball's, through its centre) the window's lit share
    // grows a column of 2r + 1 texels at a time: the 2r values j/(2r + 1), j = 1 … 2r (measured: exactly
    // those); curvature could only add partial columns. At least 2r distinct fractions: an ignored pcf
    // gives none.
    EXPECT_GE(static_cast<int>(fractional.size()), 2 * r) << "PCF gives fractional light across the edge";
  }
}

// ---------------------------------------------------------------------------------------------------
// ray_traced on spheres with a round light (shadows.light_angle)

// Share of the cone of directions within angle `light` (radians) of the axis that is NOT inside the cone
// of directions within `sphere` of a direction at angle `gamma` from the axis: the unblocked share of
// a round light of angular radius `light` when a sphere of angular radius `sphere` sits at `gamma`.
// Uniform over solid angle, integrated exactly over azimuth (a direction at polar angle θ, azimuth φ is
// inside the sphere's cone iff cosθ cosγ + sinθ sinγ cosφ ≥ cos(sphere), an arc of azimuth) and by the
// midpoint rule over cos θ (20,000 rings: error ≪ 1e-4).
double unblocked_share(double light, double sphere, double gamma) {
  const int rings = 20000;
  const double c0 = std::cos(light), cs = std::cos(sphere), cg = std::cos(gamma), sg = std::sin(gamma);
  double blocked = 0;
  for (int i = 0; i < rings; ++i) {
    const double ct = 1 - (i + 0.5) / rings * (1 - c0), st = std::sqrt(std::max(0.0, 1 - ct * ct));
    const double denom = st * sg;
    double arc;  // share of the ring inside the sphere's cone
    if (denom < 1e-12) arc = ct * cg >= cs ? 1 : 0;
    else arc = std::acos(std::clamp((cs - ct * cg) / denom, -1.0, 1.0)) / 3.14159265358979323846;
    blocked += arc;
  }
  return 1 - blocked / rings;
}

// One sphere (radius 0.2, centre 1 above a floor) under a directional light straight down of angular
// radius 10°; floor receivers x ∈ [0, 0.6] from under its centre. The closed form (unblocked_share) has
// an umbra where the sphere's cone (asin(0.2/d) ≈ 11.5°) covers the light's, a penumbra to
// γ = 21.5° (x ≈ 0.4) and full light beyond. The reference estimates the share with N shadow rays
// (a rotated lattice over the light's cone): unbiased, with a standard deviation at most the binomial
// σ = √(f(1 − f)/N) (stratification only lowers it). Tolerance per receiver 4σ + 1/N (the 1/N: the
// estimate is a multiple of 1/N), and the mean signed error over the penumbra's receivers within 4σ/√m
// + 1/N (independent rotations per receiver). With light_angle ignored (hard shadows) a receiver in the
// penumbra is 0 or 1, up to 0.5 off: 4σ ≤ 0.125 at N = 256, so that fails.
TEST(SphereSoftShadows, RoundLightMatchesTheClosedForm) {
  ParticleSet set;
  set.spheres = {{{0, 1, 0}, 0.2f}};
  set.colors = {pack_rgba8(Rgb(0.8f))};
  SphereBvh bvh(set);
  ShadowCasters view(Scene{}, {});
  view.set_spheres(CastingSpheres{&set, &bvh, set.bounds()});
  const float light_deg = 10;
  const int rays = 256;
  Light light;
  light.direction = {0, -1, 0};
  RayTracedShadows soft(light_deg, rays);
  soft.build(view, light);
  std::vector<SurfacePoint> pts;
  for (int i = 0; i <= 120; ++i) pts.push_back({{0.005f * static_cast<float>(i), 0, 0.0013f * static_cast<float>(i % 7)}, {0, 1, 0}, kNoSphere});
  std::vector<Rgb> got_rgb(pts.size());
  soft.transmittance(std::span<const SurfacePoint>(pts), std::span<Rgb>(got_rgb));
  std::vector<float> got;
  for (const Rgb& c : got_rgb) got.push_back(c.r);
  int umbra = 0, penumbra = 0, lit = 0;
  double signed_sum = 0, var_sum = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const Vec3 to_centre = Vec3{0, 1, 0} - pts[i].position;
    const double d = length(to_centre);
    const double want = unblocked_share(light_deg * 3.14159265358979323846 / 180, std::asin(0.2 / d), std::acos(to_centre.y / d));
    const double sigma = std::sqrt(want * (1 - want) / rays);
    EXPECT_NEAR(got[i], want, 4 * sigma + 1.0 / rays) << "x " << pts[i].position.x;
    if (want < 1e-9) ++umbra;
    else if (want > 1 - 1e-9) ++lit;
    else {
      ++penumbra;
      signed_sum += got[i] - want;
      var_sum += sigma * sigma;
    }
  }
  EXPECT_GE(umbra, 2);
  EXPECT_GE(penumbra, 60);
  EXPECT_GE(lit, 20);
  EXPECT_NEAR(signed_sum / penumbra, 0.0, 4 * std::sqrt(var_sum) / penumbra + 1.0 / rays) << "biased on average";
}

// The same through the scene file and the Renderer: `shadows.light_angle` reaches the sphere technique,
// and the floor beside a sphere (light tilted so that the shadow is not hidden under the sphere from
// the camera above) gets a penumbra: pixels strictly between the umbra's and the lit floor's brightness
// that the hard shadow (light_angle 0) does not have.
TEST(SphereSoftShadows, LightAngleReachesTheRenderer) {
  auto frame = [](double angle) {
    nlohmann::json j = nlohmann::json::parse(R"({
      "particles": [ { "procedural": { "name": "random-spheres", "count": 1, "radius": 0.2, "seed": 1 }, "origin": [0, 0.6, 0] } ],
      "planes": [ { "point": [0, -0.4, 0], "normal": [0, 1, 0], "color": [0.8, 0.8, 0.8], "size": 6 } ],
      "lights": [ { "type": "directional", "direction": [0.6, -1, 0] } ],
      "camera": { "eye": [0, 3, 0.01], "target": [0, -0.4, 0], "fov_deg": 50, "width": 48, "height": 48 },
      "shadows": { "technique": "ray_traced", "area_rays": 64 },
      "background": [0, 0, 0]
    })");
    j["shadows"]["light_angle"] = angle;
    const Scene s = build_scene(j, "");
    return Renderer(s).render().image;
  };
  const Image hard = frame(0), soft = frame(8);
  FailureImages keep;
  keep.add("soft_vs_hard", soft, hard);
  // The penumbra's width on the floor is ≈ 2·tan 8°·(height 1 over the floor)/cos(tilt) ≈ 0.33, about 5
  // pixels of this view (0.067 per pixel), around a shadow ≈ 0.4 across: a ring of well over 20 pixels
  // whose light changes, by up to half the diffuse term (0.8·0.8·0.86/2 ≈ 0.27) at its middle.
  std::size_t changed = 0;
  for (std::size_t i = 0; i < hard.pixels().size(); ++i) changed += std::abs(hard.pixels()[i].g - soft.pixels()[i].g) > 0.05f;
  std::printf("[ soft     ] %zu pixels changed, max %.3f\n", changed, compare_images(hard, soft).max_abs);
  EXPECT_GT(compare_images(hard, soft).max_abs, 0.15) << "light_angle changes the image";
  EXPECT_GE(changed, 20u) << "a penumbra ring";
}

// ---------------------------------------------------------------------------------------------------
// sphere_renderer: embree through the Renderer

// The Embree renderer finds each pixel's nearest sphere by rays, the default by splatting: through the
// Renderer (BVH built for it, frame camera used, shading and shadows the same) the two images must be
// the same except on silhouettes, where grazing rays and float rounding decide (SphereHits test: ≤ 0.1 %
// of pixels). Checked for the scene's camera and an orbited one (a renderer that traced the scene's
// camera for every frame would fail there), with ISSM shadows and particle AO on. Bounds: ≤ 1 % of
// pixels differ by more than 2/255 and the PSNR ≥ 35 dB, while an image without spheres scores
// < 20 dB against the same (asserted): a renderer that drew nothing fails.
TEST(SphereRenderer, EmbreeMatchesSplattingThroughTheRenderer) {
  nlohmann::json j = nlohmann::json::parse(R"({
    "particles": [ { "procedural": { "name": "random-spheres", "count": 600, "radius": 0.05, "seed": 5 } } ],
    "planes": [ { "point": [0, -0.7, 0], "normal": [0, 1, 0], "color": [0.85, 0.85, 0.85], "size": 4 } ],
    "lights": [ { "type": "directional", "direction": [-0.4, -1.0, -0.3] } ],
    "camera": { "eye": [1.6, 1.1, 2.0], "target": [0, -0.15, 0], "fov_deg": 40, "width": 64, "height": 48 },
    "shadows": { "technique": "issm", "resolution": 256 },
    "ambient": { "technique": "particle_ao" },
    "background": [0.1, 0.1, 0.12]
  })");
  nlohmann::json e = j;
  e["sphere_renderer"] = "embree";
  nlohmann::json empty = j;
  empty["particles"][0]["procedural"]["count"] = 1;
  empty["particles"][0]["procedural"]["radius"] = 1e-4;
  const Scene splat_scene = build_scene(j, ""), embree_scene = build_scene(e, ""), empty_scene = build_scene(empty, "");
  ASSERT_EQ(embree_scene.sphere_rasterizer, SphereRasterizer::Embree);
  Renderer splat(splat_scene), embree(embree_scene), nothing(empty_scene);
  FailureImages keep;
  for (const float orbit : {0.0f, 0.7f}) {
    SCOPED_TRACE("orbit " + std::to_string(orbit));
    const Camera cam = splat_scene.camera.orbited(orbit);
    const FrameResult a = splat.render(cam, splat_scene.lights), b = embree.render(cam, embree_scene.lights);
    const Image blank = nothing.render(cam, empty_scene.lights).image;
    keep.add("embree_orbit" + std::to_string(orbit), b.image, a.image);
    EXPECT_GT(embree.bvh_memory_bytes(), 0u);
    EXPECT_GT(b.sphere_pixels, a.image.pixels().size() / 10) << "spheres cover the view";
    EXPECT_NEAR(static_cast<double>(b.sphere_pixels), static_cast<double>(a.sphere_pixels), 0.01 * static_cast<double>(a.sphere_pixels));
    std::size_t differ = 0;
    for (std::size_t i = 0; i < a.image.pixels().size(); ++i) {
      const Rgb p = a.image.pixels()[i], q = b.image.pixels()[i];
      differ += std::max({std::abs(p.r - q.r), std::abs(p.g - q.g), std::abs(p.b - q.b)}) > 2.0f / 255.0f;
    }
    const double psnr = compare_images(b.image, a.image).psnr, psnr_blank = compare_images(blank, a.image).psnr;
    std::printf("[ embree   ] orbit %.1f: %zu of %zu pixels differ, PSNR %.2f dB (no spheres: %.2f dB)\n", orbit, differ,
                a.image.pixels().size(), psnr, psnr_blank);
    EXPECT_LE(static_cast<double>(differ), 0.01 * static_cast<double>(a.image.pixels().size()));
    EXPECT_LT(psnr_blank, 20.0);
    EXPECT_GT(psnr, 35.0);
  }
}

}  // namespace

// The failure-output helper itself: write_failure_images puts the rendered image, the reference and a
// difference image (same size, red where they differ most, black where equal) into
// $PENUMBRA_TEST_OUTPUT, named after the running test.
TEST(ImageCheck, WritesRenderedReferenceAndDifference) {
  ScratchDir dir;
  const char* before = std::getenv("PENUMBRA_TEST_OUTPUT");
  const std::string saved = before != nullptr ? before : "";
  ::setenv("PENUMBRA_TEST_OUTPUT", dir.path().c_str(), 1);
  Image a(8, 6, Rgb(0.5f)), b(8, 6, Rgb(0.5f));
  b.at(3, 2) = Rgb(1.0f);
  const std::string base = write_failure_images("pair", a, b);
  if (before != nullptr) ::setenv("PENUMBRA_TEST_OUTPUT", saved.c_str(), 1);
  else ::unsetenv("PENUMBRA_TEST_OUTPUT");
  EXPECT_EQ(base, (dir.path() / "ImageCheck.WritesRenderedReferenceAndDifference.pair").string());
  const Image rendered = read_image(base + ".rendered.png"), reference = read_image(base + ".reference.png"),
              diff = read_image(base + ".difference.png");
  EXPECT_NEAR(rendered.at(0, 0).r, 0.5f, 0.01f) << "8-bit PNG of 0.5";
  EXPECT_NEAR(reference.at(3, 2).r, 1.0f, 1e-6f);
  ASSERT_EQ(diff.width(), 8);
  ASSERT_EQ(diff.height(), 6);
  EXPECT_GT(diff.at(3, 2).r, 0.5f) << "the differing pixel is marked";
  EXPECT_EQ(diff.at(0, 0).r + diff.at(0, 0).g + diff.at(0, 0).b, 0.0f) << "equal pixels are black";
}
