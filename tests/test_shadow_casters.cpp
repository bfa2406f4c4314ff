// Opaque planes shadow the volume and each other in every map technique, wherever they lie relative
// to the volume's box and whatever the light type (issue 12 §1: a plane between a directional light
// and the box was ignored by shadow_map, deep_shadow_map and cssm, because the map's texel rays began
// at the box's near face).
//
// For each placement (above, inside, below and beside the box) and each light (directional, point,
// spot), receivers on a grid are classified geometrically, in double precision and independently of
// the renderer: a receiver whose ray to the light crosses the plane's square at least `kMargin` inside
// its edges is in the plane's shadow (every technique must give 0); one whose ray misses the square by
// at least `kMargin`, or meets the plane's infinite extension only behind the light, is clear (every
// technique must give the ray-traced transmittance of the faint medium, within its own tolerance).
// Receivers nearer the plane than kMargin, or within kMargin of the shadow's edge, are skipped:
// there the answer depends on the map's resolution and bias, which other tests cover.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <vector>

#include "penumbra/render/renderer.h"
#include "penumbra/shadows/ray_traced.h"
#include "penumbra/registry/registry.h"
#include "image_check.h"
#include "test_scenes.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

// Map resolution 128 over a padded unit box: a texel is < 0.01 world units; CSSM reads texels up to 7
// away (0.07) and the slope-scaled bias is a few texels, so 0.12 keeps every classified receiver clear
// of the shadow edge by more than any technique's reach.
constexpr double kMargin = 0.12;

struct Placement {
  const char* name;
  Vec3 point, normal;
  float size;
};

struct LightCase {
  const char* name;
  nlohmann::json light;
};

// Ray from p towards the light: direction (unit) and distance (infinity for directional lights).
void towards_light(const Light& light, const Vec3& p, double d[3], double& distance) {
  Vec3 to;
  float dist;
  light.towards(p, to, dist);
  d[0] = to.x, d[1] = to.y, d[2] = to.z;
  distance = dist;
}

// +1: in the plane's shadow by kMargin; −1: clear by kMargin; 0: too close to call.
int classify(const Placement& pl, const Light& light, const Vec3& p) {
  double d[3], distance;
  towards_light(light, p, d, distance);
  const double n[3] = {pl.normal.x, pl.normal.y, pl.normal.z};
  const double denom = n[0] * d[0] + n[1] * d[1] + n[2] * d[2];
  if (std::abs(denom) < 1e-9) return -1;  // the ray runs parallel to the plane
  const double t = ((pl.point.x - p.x) * n[0] + (pl.point.y - p.y) * n[1] + (pl.point.z - p.z) * n[2]) / denom;
  if (t <= 0 || t >= distance) return -1;  // the plane's extension is behind the receiver or the light
  if (t < kMargin) return 0;               // the receiver almost touches the plane
  // In-plane coordinates of the crossing, along the plane's frame (the one Plane::intersect uses).
  const Frame f = Frame::from_w(pl.normal);
  const double c[3] = {p.x + t * d[0] - pl.point.x, p.y + t * d[1] - pl.point.y, p.z + t * d[2] - pl.point.z};
  const double a = std::abs(c[0] * f.u.x + c[1] * f.u.y + c[2] * f.u.z);
  const double b = std::abs(c[0] * f.v.x + c[1] * f.v.y + c[2] * f.v.z);
  const double half = 0.5 * pl.size;
  if (a < half - kMargin && b < half - kMargin) return 1;
  if (a > half + kMargin || b > half + kMargin) return -1;
  return 0;
}

void check_placement(const Placement& pl, const LightCase& lc, const std::vector<Vec3>& receivers) {
  nlohmann::json j = full_box_scene(24, constant_tf(0.01));
  j["lights"] = nlohmann::json::array({lc.light});
  j["planes"] = nlohmann::json::array(
      {{{"point", {pl.point.x, pl.point.y, pl.point.z}}, {"normal", {pl.normal.x, pl.normal.y, pl.normal.z}}, {"size", pl.size}}});
  MediumHolder h(j);
  const Light& light = h.scene.lights[0];
  RayTracedShadows reference;
  reference.build(*h.medium, light);
  int shadowed = 0, clear = 0;
  for (const Vec3& p : receivers) {
    const int c = classify(pl, light, p);
    shadowed += c > 0;
    clear += c < 0;
  }
  // The placements are chosen so that both kinds of receiver exist; otherwise the check is empty.
  ASSERT_GE(shadowed, 6);
  ASSERT_GE(clear, 6);
  for (const char* technique : {"ray_traced", "shadow_map", "deep_shadow_map", "cssm"}) {
    SCOPED_TRACE(technique);
    ShadowSettings s;
    s.technique = technique;
    s.params.set("resolution", 128);
    auto t = make_shadow_technique(s);
    t->build(*h.medium, light);
    int failures = 0;
    for (const Vec3& p : receivers) {
      const int c = classify(pl, light, p);
      if (c == 0) continue;
      const Rgb T = t->transmittance(p), R = reference.transmittance(p);
      if (c > 0) {
        if (T.max_component() != 0.0f && failures++ < 5)
          ADD_FAILURE() << "receiver (" << p.x << ", " << p.y << ", " << p.z << ") is behind the plane but gets " << T.r;
        continue;
      }
      // Clear receivers see the faint medium only (T ≥ 0.5 along any path through the box). The classic
      // map is binary: 1 where the opacity stays below 0.5; CSSM is a mean of m = 13 Bernoulli tests,
      // σ = √(T(1 − T)/13), allowed 4σ; the deep map interpolates the exact function (0.02).
      const std::string name = technique;
      const float tol = name == "shadow_map" ? 1.0f - R.r + 1e-6f
                        : name == "cssm"     ? 4.0f * std::sqrt(R.r * (1.0f - R.r) / 13.0f) + 0.02f
                                             : 0.02f;
      if (std::abs(T.r - R.r) > tol && failures++ < 5)
        ADD_FAILURE() << "receiver (" << p.x << ", " << p.y << ", " << p.z << ") is clear of the plane: expected "
                      << R.r << " ± " << tol << ", got " << T.r;
    }
    EXPECT_EQ(failures, 0);
  }
}

// Receivers: a grid inside the box, and with `below` a column under it (where a plane below the box
// casts; it lies inside the light frusta of the lights from above, which are fitted to the box).
std::vector<Vec3> receivers(bool below) {
  std::vector<Vec3> r;
  for (int i = 0; i < 7; ++i)
    for (int k = 0; k < 7; ++k) {
      const float x = -0.42f + 0.14f * static_cast<float>(i), z = -0.42f + 0.14f * static_cast<float>(k);
      for (float y : {-0.4f, -0.1f, 0.15f, 0.4f}) r.push_back({x, y, z});
      if (below && std::abs(x) < 0.3f && std::abs(z) < 0.3f)
        for (float y : {-1.0f, -1.2f}) r.push_back({x, y, z});
    }
  return r;
}

const std::vector<LightCase>& lights_from_above() {
  static const std::vector<LightCase> cases{
      {"directional", {{"type", "directional"}, {"direction", {0.0, -1.0, 0.0}}}},
      {"directional_oblique", {{"type", "directional"}, {"direction", {0.3, -1.0, 0.2}}}},
      {"point", {{"type", "point"}, {"position", {0.1, 3.0, -0.1}}}},
      {"spot", {{"type", "spot"}, {"position", {-0.1, 3.5, 0.1}}, {"direction", {0.0, -1.0, 0.0}}, {"angle_deg", 40.0}}},
  };
  return cases;
}

void check_from_above(const Placement& pl) {
  const auto r = receivers(true);
  for (const auto& lc : lights_from_above()) {
    SCOPED_TRACE(lc.name);
    check_placement(pl, lc, r);
  }
}

}  // namespace

TEST(ShadowCasters, PlaneAboveTheBoxShadowsItInEveryMapTechnique) {
  check_from_above({"above", {-0.1f, 0.8f, 0.05f}, {0, 1, 0}, 0.6f});
}

TEST(ShadowCasters, PlaneInsideTheBoxShadowsBelowIt) {
  check_from_above({"inside", {0.1f, 0.25f, -0.05f}, {0, 1, 0}, 0.6f});
}

TEST(ShadowCasters, PlaneBelowTheBoxShadowsWhatLiesUnderIt) {
  check_from_above({"below", {0.0f, -0.8f, 0.0f}, {0, 1, 0}, 0.8f});
}

// Beside the box: a tilted plane to its side, lit from the side so that its shadow falls into the box
// (receivers in the box only: below it they would lie outside the point and spot lights' frusta, which
// are fitted to the volume, and such receivers are lit by design, docs/ARCHITECTURE.md).
TEST(ShadowCasters, PlaneBesideTheBoxShadowsIntoIt) {
  const Placement pl{"beside", {-0.9f, 0.1f, 0.0f}, normalize(Vec3{-1.0f, 1.0f, 0.0f}), 0.9f};
  const std::vector<LightCase> cases{
      {"directional", {{"type", "directional"}, {"direction", {1.0, -0.6, 0.0}}}},
      {"point", {{"type", "point"}, {"position", {-4.0, 2.5, 0.0}}}},
      {"spot", {{"type", "spot"}, {"position", {-4.0, 2.5, 0.0}}, {"direction", {1.0, -0.6, 0.0}}, {"angle_deg", 35.0}}},
  };
  const auto r = receivers(false);
  for (const auto& lc : cases) {
    SCOPED_TRACE(lc.name);
    check_placement(pl, lc, r);
  }
}

// The reproduction through the whole renderer: a faint slab filling its box, a small plane
// above it and a floor below, a directional light straight down. The plane's shadow falls through the
// volume onto the floor. Each map technique's frame must be closer to the ray-traced frame than the
// unshadowed frame is, by a wide margin (the old code rendered exactly the `none` frame).
TEST(ShadowCasters, PlaneAboveTheVolumeShadowsTheFloorThroughItInTheFrame) {
  nlohmann::json j = full_box_scene(24, constant_tf(0.01, 0.9, 0.9, 0.9));
  j["lights"] = nlohmann::json::array({{{"type", "directional"}, {"direction", {0.0, -1.0, 0.0}}}});
  j["planes"] = nlohmann::json::array({{{"point", {0.0, 0.8, 0.0}}, {"normal", {0.0, 1.0, 0.0}}, {"size", 0.4}},
                                      {{"point", {0.0, -0.7, 0.0}}, {"normal", {0.0, 1.0, 0.0}}, {"size", 3.0}}});
  j["camera"] = {{"width", 64}, {"height", 64}, {"eye", {0.0, 0.6, 2.6}}, {"target", {0.0, -0.4, 0.0}}};
  auto frame = [&](const char* technique) {
    nlohmann::json k = j;
    k["shadows"] = {{"technique", technique}, {"resolution", 256}};
    return Renderer(build_scene(k, "")).render().image;
  };
  const Image reference = frame("ray_traced"), none = frame("none");
  const double none_psnr = compare_images(none, reference).psnr;
  FailureImages keep;
  for (const char* technique : {"shadow_map", "deep_shadow_map", "cssm"}) {
    SCOPED_TRACE(technique);
    const Image image = frame(technique);
    keep.add(technique, image, reference);
    // The shadow covers a sizeable part of the frame, so `none` sits far below; every map renders the
    // same hard shadow of an opaque square and differs from the reference only along its edge (a texel
    // of 256 over the box) and, for cssm, by its 13-sample noise in the faint medium: 10 dB is margin.
    EXPECT_GT(compare_images(image, reference).psnr, none_psnr + 10.0) << "none scores " << none_psnr << " dB";
  }
}
