// Shadow techniques against closed forms and against the exact reference (DESIGN.md "Testing, the way
// rendering people test"): the ray-traced transmittance against (1 − a)^(L/Δref) and the discrete colour
// model; CSSM's mean over seeds against the reference (unbiasedness) and its single-seed noise; the deep
// shadow map converging as its node count grows, and keeping coloured shadows coloured; the classic
// map switching where the accumulated opacity crosses 0.5; the light projection's round trip.
//
// Every tolerance is derived in a comment next to it; none was tuned until green.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>
#include <utility>
#include <vector>

#include "penumbra/registry/technique_catalog.h"
#include "penumbra/core/error.h"
#include "penumbra/core/rng.h"
#include "penumbra/shadows/cssm.h"
#include "penumbra/shadows/deep_shadow_map.h"
#include "penumbra/scene/light_projection.h"
#include "penumbra/shadows/ray_traced.h"
#include "penumbra/registry/registry.h"
#include "penumbra/shadows/shadow_map.h"
#include "test_scenes.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

Vec3 unit(float x, float y, float z) { return normalize(Vec3{x, y, z}); }

// Query through the base class (the concrete classes' batched override hides the one-point overload).
Rgb transmittance_at(const ShadowTechnique& t, const Vec3& p) { return t.transmittance(p); }

std::unique_ptr<ShadowTechnique> build_technique(const ShadowSettings& s, const ShadowCasters& medium, const Light& light) {
  auto t = make_shadow_technique(s);
  t->build(medium, light);
  return t;
}

// A deterministic unit vector from two uniform numbers.
Vec3 direction_from(float u1, float u2) {
  const float z = 2 * u1 - 1, phi = 2 * kPi * u2, s = std::sqrt(std::max(0.0f, 1 - z * z));
  return {s * std::cos(phi), s * std::sin(phi), z};
}

}  // namespace

// ---------------------------------------------------------------------------------------------------
// 1. Closed forms of the reference.

// A slab thicker than the box fills the whole box with density 1. With a black transfer function of
// constant opacity a per voxel, every segment of length ℓ passes (1 − a)^(ℓ/Δref) (opacity correction),
// so the product along any path is (1 − a)^(L/Δref) whatever the step: L = length of the path inside
// the box (computed here in double, independently of Box3::clip).
// Tolerance 1e-4 (DESIGN.md): the product has at most L/Δ ≈ √3·31/0.5 ≈ 110 float factors, each with a
// relative rounding error ≈ 6e-8, so the accumulated error is below 1e-5; 1e-4 leaves a margin of 10
// and still fails for an off-by-one segment (one factor of 0.94 changes T by ≥ 2e-3 here).
TEST(ShadowsClosedForm, HomogeneousBoxMatchesPowerLaw) {
  const double a = 0.06;
  for (const double step : {-1.0, 0.5, 0.37}) {  // -1: the default light step
    SCOPED_TRACE("shadows.step " + std::to_string(step));
    nlohmann::json j = full_box_scene(32, constant_tf(a));
    j["shadows"]["step"] = step;
    MediumHolder m(j);
    const double h = m.voxel();
    ASSERT_NEAR(h, 1.0 / 31.0, 1e-7);
    struct Case { Vec3 origin, dir; float t_end; };
    std::vector<Case> cases{
        {{-0.2f, 0.1f, 0.05f}, unit(1, 0, 0), kInfinity},        // inside, along an axis to the exit
        {{0, 0, 0}, unit(1, 1, 1), kInfinity},                   // centre to a corner
        {{-2, 0.1f, -0.05f}, unit(1, 0, 0), kInfinity},           // through the whole box
        {{-1.5f, -1.2f, -0.9f}, unit(1.5f, 1.1f, 0.8f), kInfinity},  // oblique, from outside
        {{0.3f, -0.1f, 0.2f}, unit(-0.3f, 0.8f, -0.5f), 0.37f},   // inside, ends inside
        {{0.9f, 0.2f, -1.1f}, unit(-0.6f, -0.1f, 0.9f), 1.6f},    // from outside, ends inside
    };
    for (int i = 0; i < 24; ++i) {  // and random chords through the box
      const Vec3 d = direction_from(uniform_float(11, i, 0), uniform_float(11, i, 1));
      const Vec3 through{uniform_float(11, i, 2) * 0.8f - 0.4f, uniform_float(11, i, 3) * 0.8f - 0.4f,
                         uniform_float(11, i, 4) * 0.8f - 0.4f};
      cases.push_back({through - d * 2.0f, d, kInfinity});
    }
    for (const auto& c : cases) {
      const double L = length_in_box(c.origin, c.dir, 0, c.t_end);
      ASSERT_GT(L, 0.05);
      const double expected = std::pow(1 - a, L / h);
      const Rgb T = m.medium->transmittance(Ray{c.origin, c.dir}, 0, c.t_end);
      for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(T[ch], expected, 1e-4) << "L = " << L;
    }

    // The same through RayTracedShadows: a directional light (path = distance to the box's exit towards
    // the light) and point lights outside and inside the box.
    RayTracedShadows rt;
    const std::vector<Light> lights{
        Light{LightType::Directional, {}, unit(0.3f, -1, 0.2f)},
        Light{LightType::Point, {1.3f, 2.1f, -0.7f}},
        Light{LightType::Point, {0.35f, 0.3f, -0.25f}},  // inside the box: a ray tracer handles it
    };
    for (const Light& light : lights) {
      rt.build(*m.medium, light);
      for (const Vec3 p : {Vec3{0, 0, 0}, Vec3{-0.4f, -0.3f, 0.45f}, Vec3{0.2f, -0.45f, 0.1f}, Vec3{0.1f, -1.2f, 0.3f}}) {
        Vec3 to_light;
        float distance;
        light.towards(p, to_light, distance);
        const double L = length_in_box(p, to_light, 0, distance);
        const Rgb T = transmittance_at(rt, p);
        EXPECT_NEAR(T.g, std::pow(1 - a, L / h), 1e-4) << "light " << to_string(light.type) << " L = " << L;
      }
    }
  }
}

// A coloured transmission colour t makes the model discrete: a full segment of length Δ has opacity
// α_Δ = 1 − (1 − a)^(Δ/Δref) and passes 1 − α_Δ(1 − t_λ) of channel λ, so n full segments pass
// T_λ = (1 − α_Δ(1 − t_λ))^n. This is not a function of the path length alone unless t ∈ {0, 1}
// (for t = 1: exactly 1; for t = 0: (1 − a)^(nΔ/Δref)). Paths start inside the box at t = 0 (the segment
// lattice starts at the ray origin) and end at nΔ, so all n segments are full.
// Tolerance 1e-4 as above (≤ 80 float factors). The test also checks that it can tell this model from
// the step-independent guess (1 − a(1 − t))^(L/Δref): for the green channel the two differ by > 1e-3.
TEST(ShadowsClosedForm, ColouredTransmissionFollowsDiscreteModel) {
  const double a = 0.1;
  const double t[3] = {1.0, 0.5, 0.1};
  nlohmann::json j = full_box_scene(32, constant_tf(a, t[0], t[1], t[2]));
  j["shadows"]["step"] = 0.5;
  MediumHolder m(j);
  const double h = m.voxel(), delta = m.medium->step();
  ASSERT_NEAR(delta, 0.5 * h, 1e-7);
  const double alpha_delta = 1 - std::pow(1 - a, delta / h);
  struct Case { Vec3 origin, dir; int n; };
  const std::vector<Case> cases{{{-0.4f, 0.1f, 0.05f}, unit(1, 0, 0), 40},
                                {{-0.3f, -0.3f, -0.3f}, unit(1, 1, 1), 60},
                                {{0.35f, 0.4f, -0.1f}, unit(-0.5f, -0.7f, 0.2f), 25},
                                {{0.0f, 0.2f, 0.0f}, unit(0.1f, -1, 0.3f), 5}};
  RayTracedShadows rt;
  for (const auto& c : cases) {
    const float t_end = static_cast<float>(c.n) * m.medium->step();
    ASSERT_LT(t_end, length_in_box(c.origin, c.dir, 0, kInfinity)) << "the path must end inside the box";
    const Rgb T = m.medium->transmittance(Ray{c.origin, c.dir}, 0, t_end);
    // The same path through RayTracedShadows: a point light at the path's end.
    rt.build(*m.medium, Light{LightType::Point, c.origin + c.dir * t_end});
    const Rgb T_rt = transmittance_at(rt, c.origin);
    for (int ch = 0; ch < 3; ++ch) {
      const double expected = std::pow(1 - alpha_delta * (1 - t[ch]), c.n);
      EXPECT_NEAR(T[ch], expected, 1e-4) << "channel " << ch << ", n = " << c.n;
      EXPECT_NEAR(T_rt[ch], expected, 1e-4) << "channel " << ch << ", n = " << c.n << " (RayTracedShadows)";
    }
    EXPECT_EQ(T.r, 1.0f) << "a transmission colour of 1 passes all light";
    if (c.n >= 25) {
      const double naive = std::pow(1 - a * (1 - t[1]), c.n * delta / h);
      EXPECT_GT(std::abs(naive - std::pow(1 - alpha_delta * (1 - t[1]), c.n)), 1e-3) << "test cannot tell the models apart";
    }
  }
}

// A ball of density 1 (radius r) classified by a step transfer function (opacity 0 below density 0.5,
// a above) is a homogeneous medium with a voxelised boundary: T = (1 − a)^(chord/Δref) with
// chord = 2√(r² − b²) for a ray at distance b from the centre.
// Tolerance, derived: the voxels are 1 where their centre is inside the ball, so the trilinear field
// crosses 0.5 somewhere between the last voxel centre inside and the first outside: the boundary seen
// by the march is off by up to half a voxel (h/2) radially at each of the two crossings, i.e. (h/2)/cosθ
// along the ray (θ: angle between the ray and the sphere's normal, cosθ = √(r² − b²)/r); and the march
// classifies whole segments by their midpoint, which adds up to Δ/2 per crossing. So the effective
// chord is within δ = h/cosθ + Δ of the analytic one, and |T − T_exact| ≤ max over ± of
// |(1 − a)^((chord ± δ)/h) − (1 − a)^(chord/h)|. Rays are limited to b ≤ 0.7r (cosθ ≥ 0.71).
TEST(ShadowsClosedForm, SphereChordWithinBoundaryUncertainty) {
  const double a = 0.05, r = 0.3;
  const int size = sanitize_scale() ? 48 : 64;
  MediumHolder m(volume_scene({{"name", "sphere"}, {"size", size}, {"radius", r}}, step_tf(a)));
  const double h = m.voxel(), delta = m.medium->step();
  double worst_ratio = 0;
  for (int i = 0; i < 64; ++i) {
    const Vec3 d = direction_from(uniform_float(21, i, 0), uniform_float(21, i, 1));
    const Frame f = Frame::from_w(d);
    const double b = (i == 0 ? 0.0 : 0.7 * r * uniform_float(21, i, 2));
    const double phi = 2 * kPi * uniform_float(21, i, 3);
    const Vec3 offset = f.u * static_cast<float>(b * std::cos(phi)) + f.v * static_cast<float>(b * std::sin(phi));
    const Rgb T = m.medium->transmittance(Ray{offset - d * 2.0f, d}, 0, kInfinity);
    const double chord = 2 * std::sqrt(r * r - b * b);
    const double cos_theta = std::sqrt(r * r - b * b) / r;
    const double slack = h / cos_theta + delta;
    const double exact = std::pow(1 - a, chord / h);
    const double tol = std::max(std::abs(std::pow(1 - a, (chord - slack) / h) - exact),
                                std::abs(std::pow(1 - a, (chord + slack) / h) - exact));
    EXPECT_NEAR(T.r, exact, tol) << "b = " << b << ", chord = " << chord;
    worst_ratio = std::max(worst_ratio, std::abs(T.r - exact) / tol);
  }
  // Measured: the worst ray uses about 0.7 of its allowance at 32³ and 64³.
  RecordProperty("worst_error_over_tolerance", std::to_string(worst_ratio));
}

// ---------------------------------------------------------------------------------------------------
// 2. Colored stochastic shadow map.

TEST(ShadowsCssm, OffsetSetsAreCentrallySymmetric) {
  // The paper's 13: {(0,0), (±3,±3), (±4,0), (0,±4), (±7,0), (0,±7)} (§4).
  const std::set<std::pair<int, int>> paper{{0, 0},  {3, 3},  {3, -3}, {-3, 3}, {-3, -3}, {4, 0}, {-4, 0},
                                            {0, 4},  {0, -4}, {7, 0},  {-7, 0}, {0, 7},   {0, -7}};
  std::set<std::pair<int, int>> previous;
  for (const int m : {7, 13, 21}) {
    SCOPED_TRACE("offsets " + std::to_string(m));
    const auto offsets = cssm_offsets(m);
    ASSERT_EQ(offsets.size(), static_cast<std::size_t>(m));
    const std::set<std::pair<int, int>> set(offsets.begin(), offsets.end());
    EXPECT_EQ(set.size(), offsets.size()) << "duplicate offsets";
    EXPECT_EQ(offsets[0], std::make_pair(0, 0)) << "the receiver's own texel comes first";
    int sx = 0, sy = 0;
    for (const auto& [dx, dy] : offsets) {
      EXPECT_TRUE(set.count({-dx, -dy})) << "(" << dx << "," << dy << ") has no mirror image";
      sx += dx;
      sy += dy;
    }
    EXPECT_EQ(sx, 0);  // centred: the footprint does not shift the shadow
    EXPECT_EQ(sy, 0);
    if (m == 13) {
      EXPECT_EQ(set, paper);
    }
    // nested: the 7 are the smallest of the 13 (paper §4: "the 7 smallest offsets"), the 21 add larger ones
    for (const auto& o : previous) EXPECT_TRUE(set.count(o)) << "not nested";
    if (m == 7) {
      for (const auto& [dx, dy] : offsets) EXPECT_LE(dx * dx + dy * dy, 18);
    }
    if (m == 21) {
      for (const auto& o : set) {
        if (!paper.count(o)) {
          EXPECT_GE(o.first * o.first + o.second * o.second, 49);
        }
      }
    }
    previous = set;
  }
  EXPECT_THROW(cssm_offsets(5), Error);
  EXPECT_THROW(cssm_offsets(0), Error);
}

namespace {

// CSSM in a homogeneous coloured medium (the whole box, a = 0.045 per voxel, t = (0.9, 0.5, 0.1)) under
// a tilted directional light (0.2, −1, 0.1), at 5 receivers inside the box (half way down) and 5 below
// it: one on the light ray through the box centre and four 0.22 away from it across the light's view.
// Every offset texel's ray must cross the same medium for the shadow factor's expectation to be the
// transmittance at the receiver: with 128² texels of ≈ 0.0105 over the light's view of the box, the
// farthest offset (10 texels, 21 offsets) is ≈ 0.105 away, so the rays stay within 0.22 + 0.105 of the
// central one, which itself drifts by ≤ 0.1 in x from the box centre between its top and bottom faces:
// ≤ 0.43 < 0.5, the box's half width. Receivers are ≥ 0.22 ≈ 21 texels apart, more than the 20-texel
// span of the largest offset set, so no two receivers read a common texel.
void check_cssm_unbiased(int offsets, int seeds) {
  const double a = 0.045;
  nlohmann::json j = full_box_scene(32, constant_tf(a, 0.9, 0.5, 0.1));
  MediumHolder m(j);
  const Light light{LightType::Directional, {}, unit(0.2f, -1, 0.1f)};
  Vec3 to_light;
  float distance;
  light.towards({}, to_light, distance);
  const Frame lf = Frame::from_w(to_light);
  const float bias = m.medium->step();  // the default bias: one light step
  constexpr int kReceivers = 5;

  // Receivers around the light ray through the centre, at y = 0 (inside) and y = -0.7 (behind the box).
  std::vector<Vec3> receivers[2];
  for (int g = 0; g < 2; ++g) {
    const float y = g == 0 ? 0.0f : -0.7f;
    const Vec3 axis = to_light * (y / to_light.y);
    for (const Vec3 d : {Vec3{}, lf.u, lf.u * -1.0f, lf.v, lf.v * -1.0f}) receivers[g].push_back(axis + d * 0.22f);
  }

  RayTracedShadows rt;
  rt.build(*m.medium, light);
  const double alpha_delta = 1 - std::pow(1 - a, m.medium->step() / m.voxel());
  const double transmission[3] = {0.9, 0.5, 0.1};

  // shadow factors [group][receiver][seed]
  std::vector<std::vector<std::vector<Rgb>>> f(2, std::vector<std::vector<Rgb>>(kReceivers));
  for (int s = 0; s < seeds; ++s) {
    ShadowSettings settings;
    settings.technique = "cssm";
    settings.params.set("resolution", 128);
    settings.params.set("offsets", offsets);
    settings.params.set("seed", 1000 + static_cast<std::int64_t>(s));
    const auto cssm = build_technique(settings, *m.medium, light);
    for (int g = 0; g < 2; ++g)
      for (int i = 0; i < kReceivers; ++i) f[g][i].push_back(transmittance_at(*cssm, receivers[g][i]));
  }

  for (int g = 0; g < 2; ++g)
    for (int ch = 0; ch < 3; ++ch) {
      SCOPED_TRACE(std::string(g == 0 ? "inside" : "behind") + " the medium, channel " + std::to_string(ch));
      // Per seed, the mean over the receivers; then mean and standard error over seeds.
      std::vector<double> per_seed(static_cast<std::size_t>(seeds), 0.0);
      for (int s = 0; s < seeds; ++s)
        for (int i = 0; i < kReceivers; ++i) per_seed[s] += f[g][i][s][ch] / kReceivers;
      double mean = 0, var = 0;
      for (double v : per_seed) mean += v / seeds;
      for (double v : per_seed) var += (v - mean) * (v - mean) / (seeds - 1);
      const double se = std::sqrt(var / seeds);
      // The exact transmittance. Inside the medium the query compares against depth − bias, so the
      // reference point is moved by the bias towards the light.
      double ref = 0;
      for (int i = 0; i < kReceivers; ++i)
        ref += transmittance_at(rt, receivers[g][i] + (g == 0 ? to_light * bias : Vec3{}))[ch] / kReceivers;
      // Discretisation allowance (not statistics): the map's photons stop in whole segments whose
      // midpoints lie in front of the receiver's biased depth, so inside the medium the path it accounts
      // for is the reference's within ±Δ/2: a factor (1 − ρ)^(∓1/2), i.e. ≤ ref·((1 − ρ)^(−1/2) − 1).
      // Behind the medium both paths cross the whole box and differ only in where partial segments fall:
      // second order, ≤ 2ρ². ρ = α_Δ(1 − t_λ) ≤ 0.04 here.
      const double rho = alpha_delta * (1 - transmission[ch]);
      const double discretisation = g == 0 ? ref * (1 / std::sqrt(1 - rho) - 1) : 2 * rho * rho;
      // Unbiasedness: within z = 4 standard errors (two-sided false alarm 6e-5) plus the allowance.
      EXPECT_NEAR(mean, ref, 4 * se + discretisation) << "se " << se << ", seeds " << seeds;
      // The spread must be that of m independent Bernoulli texels per receiver (5 receivers whose
      // footprints do not overlap): σ² = T(1 − T)/(5m). Much more means correlated random numbers; the
      // sample σ of K seeds is within ±0.3σ with probability > 0.999 for K ≥ 64.
      const double bernoulli = std::sqrt(ref * (1 - ref) / (kReceivers * offsets));
      EXPECT_LT(std::sqrt(var), 1.3 * bernoulli + 1e-6);
      EXPECT_GT(std::sqrt(var), 0.7 * bernoulli);
    }

  // One seed alone is visibly noisy: at a half-transparent receiver (green behind the box, T ≈ 0.5) the
  // per-seed values spread like the mean of m Bernoulli texels, σ = √(T(1 − T)/m) ≈ 0.14 for m = 13.
  // Allow [0.6, 1.4]σ (the sample σ of K ≥ 64 seeds has a relative standard error ≤ 0.09).
  const auto& centre = f[1][0];
  double mean = 0, var = 0;
  for (const Rgb& v : centre) mean += v.g / static_cast<double>(seeds);
  for (const Rgb& v : centre) var += (v.g - mean) * (v.g - mean) / static_cast<double>(seeds - 1);
  const double T = transmittance_at(rt, receivers[1][0]).g;
  ASSERT_GT(T, 0.3);
  ASSERT_LT(T, 0.7);
  const double sigma = std::sqrt(T * (1 - T) / offsets);
  EXPECT_GT(std::sqrt(var), 0.6 * sigma) << "a single CSSM seed should be noisy";
  EXPECT_LT(std::sqrt(var), 1.4 * sigma);
  // and it takes only the values j/m
  for (const Rgb& v : centre) {
    const float j_over_m = v.g * static_cast<float>(offsets);
    EXPECT_NEAR(j_over_m, std::round(j_over_m), 1e-4);
  }
}

}  // namespace

// K = 128 seeds for the paper's 13 offsets, 64 for the variants (64 each under the sanitizer).
TEST(ShadowsCssm, MeanOverSeedsIsUnbiased13) { check_cssm_unbiased(13, sanitize_scale() ? 64 : 128); }
TEST(ShadowsCssm, MeanOverSeedsIsUnbiased7) { check_cssm_unbiased(7, 64); }
TEST(ShadowsCssm, MeanOverSeedsIsUnbiased21) { check_cssm_unbiased(21, 64); }

// Same seed, same map: the generation is a pure function of (seed, texel, segment).
TEST(ShadowsCssm, SeedDeterminesTheMap) {
  MediumHolder m(full_box_scene(32, constant_tf(0.045, 0.9, 0.5, 0.1)));
  const Light light{LightType::Directional, {}, unit(0.2f, -1, 0.1f)};
  ShadowSettings s;
  s.technique = "cssm";
  s.params.set("resolution", 32);
  s.params.set("seed", 5);
  const auto a = build_technique(s, *m.medium, light), b = build_technique(s, *m.medium, light);
  s.params.set("seed", 6);
  const auto c = build_technique(s, *m.medium, light);
  const auto& ma = dynamic_cast<const ColoredStochasticShadowMap&>(*a);
  const auto& mb = dynamic_cast<const ColoredStochasticShadowMap&>(*b);
  const auto& mc = dynamic_cast<const ColoredStochasticShadowMap&>(*c);
  int differ = 0;
  for (int y = 0; y < 32; ++y)
    for (int x = 0; x < 32; ++x)
      for (int ch = 0; ch < 3; ++ch) {
        ASSERT_EQ(ma.depth_at(x, y, ch), mb.depth_at(x, y, ch));
        differ += ma.depth_at(x, y, ch) != mc.depth_at(x, y, ch) ? 1 : 0;
      }
  // Independent maps agree in a texel's channel only if neither photon stopped (probability T², with
  // T ≈ 0.49 for green at the bottom of the box) or both stopped in the same segment (Σ p_i² < 0.05):
  // green alone should differ in ≳ 70% of the 1024 texels; ask for a quarter.
  EXPECT_GT(differ, 32 * 32 / 4) << "another seed should give another map";
}

// ---------------------------------------------------------------------------------------------------
// 3. Deep shadow map.

namespace {

struct DsmReceivers {
  std::vector<Vec3> points;
  std::vector<Rgb> reference;
};

// The Marschner–Lobb volume under a linear transfer function (opacity 0.08·density, transmission
// colour (0.9, 0.5, 0.2)) gives smooth, many-times-bending transmittance functions along light rays.
// Receivers sit on texel-centre rays of the map at segment ends of the light ray's lattice (depth kΔ),
// with bias 0: there the uncompressed deep shadow function is exactly the product of whole segments, and
// the ray-traced reference, marching from the receiver back along the same line, uses the same lattice,
// so the two agree exactly (checked below) and every error left is the map's node compression.
// Receivers with T > 0.98 or < 0.02 in every channel are skipped (every technique gets those right).
// Run for both layouts (`shadows.dsm_layout`); the bounds are the same, derived below.
void check_error_falls_as_nodes_grow(const std::string& layout) {
  const int size = sanitize_scale() ? 32 : 48, res = 64;
  nlohmann::json j = volume_scene({{"name", "marschner-lobb"}, {"size", size}},
                                  {{"points", {{0.0, 0.9, 0.5, 0.2, 0.0}, {1.0, 0.9, 0.5, 0.2, 0.08}}}});
  MediumHolder m(j);
  const Light light{LightType::Directional, {}, unit(0.3f, -1, 0.2f)};
  RayTracedShadows rt;
  rt.build(*m.medium, light);
  const float delta = m.medium->step();

  ShadowSettings s;
  s.technique = "deep_shadow_map";
  s.params.set("dsm_layout", layout);
  s.params.set("resolution", res);
  s.params.set("bias", 0);
  s.params.set("nodes", 2);
  const auto probe = build_technique(s, *m.medium, light);
  const LightProjection& proj = dynamic_cast<const DeepShadowMap&>(*probe).projection();
  const Box3 box = m.scene.visible_volume()->volume->bounds();
  DsmReceivers rx;
  for (int i = 0; rx.points.size() < 300 && i < 20000; ++i) {
    const int ix = static_cast<int>(uniform_float(31, i, 0) * res), iy = static_cast<int>(uniform_float(31, i, 1) * res);
    const Ray ray = proj.texel_ray((static_cast<float>(ix) + 0.5f) / res, (static_cast<float>(iy) + 0.5f) / res);
    float t0, t1;
    if (!box.clip(ray, t0, t1)) continue;
    const auto k0 = static_cast<long>(std::floor(t0 / delta)) + 2, k1 = static_cast<long>(std::floor(t1 / delta));
    if (k1 <= k0) continue;
    const long k = k0 + static_cast<long>(static_cast<float>(k1 - k0) * uniform_float(31, i, 2));
    const Vec3 p = ray.at(static_cast<float>(k) * delta);
    const Rgb ref = transmittance_at(rt, p);
    if (ref.max_component() > 0.98f || ref.max_component() < 0.02f) continue;
    // Same lattice: the march along the texel ray itself gives the same number.
    const Rgb along = m.medium->transmittance(ray, 0, static_cast<float>(k) * delta);
    for (int ch = 0; ch < 3; ++ch) ASSERT_NEAR(ref[ch], along[ch], 1e-5);
    rx.points.push_back(p);
    rx.reference.push_back(ref);
  }
  ASSERT_GE(rx.points.size(), 200u);

  // Mean |DSM − reference| over receivers and channels, and the worst one, per node count.
  const std::vector<int> nodes{2, 3, 4, 8, 16, 32, 64};
  std::vector<double> mean_err, max_err;
  for (const int n : nodes) {
    s.params.set("nodes", n);
    const auto dsm = build_technique(s, *m.medium, light);
    double sum = 0, worst = 0;
    for (std::size_t i = 0; i < rx.points.size(); ++i) {
      const Rgb T = transmittance_at(*dsm, rx.points[i]);
      for (int ch = 0; ch < 3; ++ch) {
        const double e = std::abs(T[ch] - rx.reference[i][ch]);
        sum += e;
        worst = std::max(worst, e);
      }
    }
    mean_err.push_back(sum / (3.0 * static_cast<double>(rx.points.size())));
    max_err.push_back(worst);
    ::testing::Test::RecordProperty(layout + "_mean_error_nodes_" + std::to_string(n), std::to_string(mean_err.back()));
  }
  // Measured (48³, 2026-12-01), per_channel: 0.056, 0.013, 0.0073, 0.0011, 2.6e-4, 6.4e-5, 7e-6;
  // shared_depth: 0.056, 0.013, 0.0082, 0.0013, 2.9e-4, 7.5e-5, 2e-6 (the channels share the node depths).
  // Non-increasing. Slack 1e-4: the compression stops inserting nodes once every vertex is within 1e-4
  // of the approximation, so below that level the error is not controlled by the node count.
  for (std::size_t i = 1; i < nodes.size(); ++i)
    EXPECT_LE(mean_err[i], mean_err[i - 1] + 1e-4) << nodes[i - 1] << " -> " << nodes[i] << " nodes";
  // Clearly lower at the end: a piecewise-linear approximation of a smooth function improves like 1/N²
  // (256× from 2 to 32 nodes); ask for 20×.
  EXPECT_LT(mean_err.back() * 20, mean_err.front());
  EXPECT_GT(mean_err.front(), 0.01) << "2 nodes should visibly miss this medium (else the test proves nothing)";
  // At 64 nodes the budget holds the whole function: a light ray crosses at most 1/|d_y|·(size − 1)
  // ≈ 1.06·47 ≈ 50 segments (< 64 vertices), so the greedy compression stops on its own tolerance 1e-4
  // (the largest vertex deviation it leaves, in every channel: shared_depth measures the largest over the
  // three). At the receivers (vertices) the error is therefore ≤ 1e-4, plus float rounding of T and of
  // the interpolation weight (< 1e-5).
  EXPECT_LE(max_err.back(), 1e-4 + 1e-5);
}

// Coloured shadows stay coloured: a ball whose transmission colour is red passes red and stops blue, in
// the deep shadow map (3 nodes, the paper's setting) as in the reference. Receivers behind the ball on
// texel-centre rays at lattice depths (bias 0), where, behind the last node, the map holds the exact
// product (see above): tolerance 1e-4 (the compression tolerance) + 1e-5 (float).
void check_coloured_medium_keeps_coloured_shadows(const std::string& layout) {
  MediumHolder m(volume_scene({{"name", "sphere"}, {"size", 32}, {"radius", 0.3}}, step_tf(0.1, 0.9, 0.3, 0.05)));
  const Light light{LightType::Directional, {}, unit(0, -1, 0)};
  RayTracedShadows rt;
  rt.build(*m.medium, light);
  ShadowSettings s;
  s.technique = "deep_shadow_map";
  s.params.set("dsm_layout", layout);
  s.params.set("resolution", 64);
  s.params.set("nodes", 3);
  s.params.set("bias", 0);
  const auto dsm = build_technique(s, *m.medium, light);
  const LightProjection& proj = dynamic_cast<const DeepShadowMap&>(*dsm).projection();
  const float delta = m.medium->step();
  int tested = 0;
  for (int ix = 22; ix < 42; ix += 3)
    for (int iy = 22; iy < 42; iy += 3) {
      const Ray ray = proj.texel_ray((static_cast<float>(ix) + 0.5f) / 64, (static_cast<float>(iy) + 0.5f) / 64);
      // just below the ball (y = -0.42), on the lattice
      float u, v, depth;
      ASSERT_TRUE(proj.project(Vec3{ray.origin.x, -0.42f, ray.origin.z}, u, v, depth));
      const Vec3 p = ray.at(std::round(depth / delta) * delta);
      const Rgb ref = transmittance_at(rt, p);
      const Rgb T = transmittance_at(*dsm, p);
      for (int ch = 0; ch < 3; ++ch) EXPECT_NEAR(T[ch], ref[ch], 1e-4 + 1e-5) << "texel " << ix << "," << iy;
      if (ref.r > 0.99f) continue;  // the ray missed the ball
      ++tested;
      // Red passes (t = 0.9), blue is stopped (t = 0.05): over a chord of ≥ 0.3 (≥ 9 voxels at a = 0.1)
      // red keeps ≥ 0.99^9 ≈ 0.91 and blue ≤ 0.905^9 ≈ 0.41.
      EXPECT_GT(T.r - T.b, 0.4f) << "the deep shadow map lost the shadow's colour";
      EXPECT_GT(T.g, T.b);
      EXPECT_GT(T.r, T.g);
    }
  EXPECT_GE(tested, 20);
}

// Closed forms in a homogeneous box (the whole box, opacity a per voxel, black: t = 0, so every channel
// passes (1 − a)^(ℓ/Δref) over a path ℓ inside the box, whatever the segments' lengths), light straight
// down, so a texel's ray enters the box at depth z_in and leaves at z_out (Box3::clip), L = z_out − z_in.
//  - 2 nodes: the compression keeps the first and last vertices only, so T(z) is the chord
//    1 + ((1 − a)^(L/Δref) − 1)·(z − z_in)/L on [z_in, z_out], 1 before and (1 − a)^(L/Δref) after.
//    Tolerance 1e-4: T_out is a product of ≤ 33 float factors (< 1e-5), z_in and the lattice vertex
//    differ by float rounding of depths ≈ 2 (≤ 1e-6 relative), and 1e-4 still fails for a node off by
//    one segment (T changes by ≥ a·T ≥ 0.005 per segment here).
//  - 64 nodes (≥ the ≤ 33 vertices of a 32-voxel chord at one voxel a step): every vertex is kept to
//    1e-4, and between vertices (≤ Δ apart) T is the chord of the exponential e^(−k(z − z_in)),
//    k = −ln(1 − a)/Δref, whose distance from the curve is at most Δ²k²/8 (the interpolation error of a
//    function with |f''| ≤ k²). So |T − (1 − a)^((z − z_in)/Δref)| ≤ 1e-4 + Δ²k²/8 + 1e-5.
void check_homogeneous_box_closed_forms(const std::string& layout) {
  const double a = 0.05;
  MediumHolder m(full_box_scene(32, constant_tf(a)));
  const Light light{LightType::Directional, {}, unit(0, -1, 0)};
  const double h = m.voxel(), delta = m.medium->step();
  const double k = -std::log(1 - a) / h;
  const Box3 box = m.scene.visible_volume()->volume->bounds();
  for (const int n : {2, 64}) {
    ShadowSettings s;
    s.technique = "deep_shadow_map";
    s.params.set("dsm_layout", layout);
    s.params.set("resolution", 32);
    s.params.set("nodes", n);
    s.params.set("bias", 0);
    const auto t = build_technique(s, *m.medium, light);
    const auto& dsm = dynamic_cast<const DeepShadowMap&>(*t);
    int checked = 0;
    for (int ix = 1; ix < 32; ix += 5)
      for (int iy = 2; iy < 32; iy += 5) {
        const Ray ray = dsm.projection().texel_ray((static_cast<float>(ix) + 0.5f) / 32, (static_cast<float>(iy) + 0.5f) / 32);
        float z_in, z_out;
        ASSERT_TRUE(box.clip(ray, z_in, z_out));
        const double L = z_out - z_in, T_out = std::pow(1 - a, L / h);
        for (int ch = 0; ch < 3; ++ch) ASSERT_EQ(dsm.node_count(ix, iy, ch), n == 2 ? 2 : dsm.node_count(ix, iy, 0));
        for (int i = -3; i <= 40; ++i) {
          const double z = z_in + L * i / 37.0;  // before, inside (off the lattice) and behind the box
          const double expected = n == 2 ? (z < z_in ? 1.0 : z > z_out ? T_out : 1 + (T_out - 1) * (z - z_in) / L)
                                         : (z < z_in ? 1.0 : std::pow(1 - a, (std::min<double>(z, z_out) - z_in) / h));
          const double tol = n == 2 ? 1e-4 : 1e-4 + delta * delta * k * k / 8 + 1e-5;
          // through the query a renderer uses (the point on the texel's ray at depth z; bias 0) and
          // through the per-channel evaluation
          const Rgb T = transmittance_at(dsm, ray.at(static_cast<float>(z)));
          for (int ch = 0; ch < 3; ++ch) {
            EXPECT_NEAR(T[ch], expected, tol) << n << " nodes, texel " << ix << "," << iy << ", z − z_in = " << z - z_in
                                              << ", channel " << ch;
            EXPECT_NEAR(dsm.evaluate(ix, iy, ch, static_cast<float>(z)), expected, tol) << "evaluate(), channel " << ch;
          }
          ++checked;
        }
      }
    EXPECT_GE(checked, 6 * 6 * 40);
  }
}

}  // namespace

TEST(ShadowsDeepShadowMap, ErrorFallsAsNodesGrow) { check_error_falls_as_nodes_grow("per_channel"); }
TEST(ShadowsDeepShadowMap, SharedDepthErrorFallsAsNodesGrow) { check_error_falls_as_nodes_grow("shared_depth"); }
TEST(ShadowsDeepShadowMap, ColouredMediumKeepsColouredShadows) { check_coloured_medium_keeps_coloured_shadows("per_channel"); }
TEST(ShadowsDeepShadowMap, SharedDepthColouredMediumKeepsColouredShadows) {
  check_coloured_medium_keeps_coloured_shadows("shared_depth");
}
TEST(ShadowsDeepShadowMap, HomogeneousBoxClosedForms) { check_homogeneous_box_closed_forms("per_channel"); }
TEST(ShadowsDeepShadowMap, SharedDepthHomogeneousBoxClosedForms) { check_homogeneous_box_closed_forms("shared_depth"); }

// A layout that does not exist is an error naming the key, in the scene file as in the technique.
TEST(ShadowsDeepShadowMap, UnknownLayoutIsAnError) {
  ShadowSettings s;
  s.technique = "deep_shadow_map";
  s.params.set("dsm_layout", "per_texel");
  EXPECT_THROW(make_shadow_technique(s), Error);
  nlohmann::json j = full_box_scene(8, constant_tf(0.1));
  j["shadows"] = {{"technique", "deep_shadow_map"}, {"dsm_layout", "per_texel"}};
  try {
    (void)build_scene(j, "");
    ADD_FAILURE() << "dsm_layout per_texel was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("dsm_layout"), std::string::npos) << e.what();
  }
}

// What distinguishes the layouts. In a coloured medium (the red ball over the Marschner–Lobb field: the
// channels bend at different depths) shared_depth keeps one set of node depths per texel: every channel
// reports the same count and the same depths, and memory is resolution²·(4N floats + 1 count byte + 1
// surface float) against per_channel's resolution²·(6N floats + 3 count bytes + 1 surface float). In a
// grey medium (equal transmission in R, G, B) the three channels' functions coincide, so the largest
// deviation over channels is each channel's own, the greedy insertion picks the same vertices, and the
// two layouts must give bit-identical transmittance.
TEST(ShadowsDeepShadowMap, SharedDepthSharesNodesAndEqualsPerChannelInGrey) {
  const int res = 32;
  const Light light{LightType::Directional, {}, unit(0.3f, -1, 0.2f)};
  auto build = [&](const MediumHolder& m, const char* layout, int nodes) {
    ShadowSettings s;
    s.technique = "deep_shadow_map";
    s.params.set("dsm_layout", layout);
    s.params.set("resolution", res);
    s.params.set("nodes", nodes);
    return build_technique(s, *m.medium, light);
  };
  {
    MediumHolder m(volume_scene({{"name", "marschner-lobb"}, {"size", 32}},
                                {{"points", {{0.0, 0.9, 0.5, 0.2, 0.0}, {1.0, 0.9, 0.5, 0.2, 0.08}}}}));
    for (const int n : {2, 3, 5}) {
      const auto shared_t = build(m, "shared_depth", n), per_t = build(m, "per_channel", n);
      const auto& shared = dynamic_cast<const DeepShadowMap&>(*shared_t);
      const auto& per = dynamic_cast<const DeepShadowMap&>(*per_t);
      EXPECT_EQ(shared.layout(), DsmLayout::SharedDepth);
      EXPECT_EQ(shared.memory_bytes(), static_cast<std::size_t>(res * res) * (4 * 4 * n + 1 + 4)) << n << " nodes";
      EXPECT_EQ(per.memory_bytes(), static_cast<std::size_t>(res * res) * (6 * 4 * n + 3 + 4)) << n << " nodes";
      int with_nodes = 0, per_channel_depths_differ = 0;
      for (int iy = 0; iy < res; ++iy)
        for (int ix = 0; ix < res; ++ix) {
          const int c = shared.node_count(ix, iy, 0);
          ASSERT_LE(c, n);
          with_nodes += c > 0 ? 1 : 0;
          for (int ch = 1; ch < 3; ++ch) {
            ASSERT_EQ(shared.node_count(ix, iy, ch), c);
            for (int j = 0; j < c; ++j) ASSERT_EQ(shared.node_depth(ix, iy, ch, j), shared.node_depth(ix, iy, 0, j));
          }
          // per_channel, in the same medium, does place some channels' nodes elsewhere (else this medium
          // would not tell the layouts apart)
          if (per.node_count(ix, iy, 0) == per.node_count(ix, iy, 2) && per.node_count(ix, iy, 0) > 2)
            for (int j = 0; j < per.node_count(ix, iy, 0); ++j)
              per_channel_depths_differ += per.node_depth(ix, iy, 0, j) != per.node_depth(ix, iy, 2, j) ? 1 : 0;
        }
      EXPECT_GT(with_nodes, res * res / 4);
      if (n > 2) {
        EXPECT_GT(per_channel_depths_differ, 0) << n << " nodes";
      }
    }
  }
  MediumHolder grey(volume_scene({{"name", "marschner-lobb"}, {"size", 32}},
                                 {{"points", {{0.0, 0.4, 0.4, 0.4, 0.0}, {1.0, 0.4, 0.4, 0.4, 0.1}}}}));
  for (const int n : {2, 3, 8}) {
    const auto shared = build(grey, "shared_depth", n), per = build(grey, "per_channel", n);
    int compared = 0;
    for (int i = 0; i < 2000; ++i) {
      const Vec3 p{uniform_float(41, i, 0) - 0.5f, uniform_float(41, i, 1) - 0.5f, uniform_float(41, i, 2) - 0.5f};
      const Rgb a = transmittance_at(*shared, p), b = transmittance_at(*per, p);
      for (int ch = 0; ch < 3; ++ch) ASSERT_EQ(a[ch], b[ch]) << n << " nodes, point " << i << ", channel " << ch;
      compared += a.r < 0.99f ? 1 : 0;
    }
    EXPECT_GT(compared, 500) << "most points should be in shadow";
  }
}

// ---------------------------------------------------------------------------------------------------
// 4. Classic shadow map.

// Accumulated opacity 1 − Π(1 − α_i) from far towards the light down to p (the reference of the
// binarised map), by ShadowCasters::march along the ray from p + to_light·far back to p.
double accumulated_opacity(const ShadowCasters& medium, const Light& light, const Vec3& p, float far = 3.0f) {
  Vec3 to_light;
  float distance;
  light.towards(p, to_light, distance);
  double transparency = 1;
  medium.march(Ray{p + to_light * far, -to_light}, 0, far, [&](const MediumSegment& s) {
    transparency *= 1 - s.alpha;
    return true;
  });
  return 1 - transparency;
}

// Receivers on one light ray through a homogeneous medium (the whole box, tilted light): all in the same
// texel. The map stores the midpoint of the segment in which the opacity along the texel's ray reaches
// 0.5, i.e. within Δ/2 of the depth d* where the exact opacity does, and a receiver is unlit once its
// depth minus the bias passes that: the switch lies at d* + bias ± Δ/2. The reference (the receiver's
// own ray, marched from a different origin) places d* within another Δ/2 (its partial segments), and
// receivers are Δ/8 apart. So the switch must be within Δ + Δ/8 of d*_ref + bias: "one shadow step plus
// bias", centred on the bias shift so that a missing or doubled bias is caught too.
TEST(ShadowsClassicMap, SwitchesWhereOpacityCrossesHalfAlongTheLight) {
  const double a = 1 - std::pow(0.5, (1.0 / 31.0) / 0.5);  // opacity 0.5 after half a unit of medium
  MediumHolder m(full_box_scene(32, constant_tf(a, 0.2, 0.9, 0.4)));  // the colour must not matter
  const Light light{LightType::Directional, {}, unit(0.3f, -1, 0.2f)};
  Vec3 to_light;
  float distance;
  light.towards({}, to_light, distance);
  ShadowSettings s;
  s.technique = "shadow_map";
  s.params.set("resolution", 64);
  const auto map = build_technique(s, *m.medium, light);
  const float delta = m.medium->step(), bias = delta, spacing = delta / 8;
  double switch_map = kInfinity, switch_ref = kInfinity;  // s along −to_light from the centre
  for (int i = 0; i < static_cast<int>(1.2f / spacing); ++i) {
    const float sdist = -0.6f + static_cast<float>(i) * spacing;
    const Vec3 p = -to_light * sdist;  // s grows away from the light
    const Rgb T = transmittance_at(*map, p);
    EXPECT_EQ(T.r, T.g);  // the classic map is colour-blind
    EXPECT_EQ(T.r, T.b);
    EXPECT_TRUE(T.r == 0.0f || T.r == 1.0f);
    if (T.r == 0.0f && switch_map == kInfinity) switch_map = sdist;
    if (T.r == 1.0f && switch_map != kInfinity) ADD_FAILURE() << "lit again after the switch at s = " << sdist;
    if (accumulated_opacity(*m.medium, light, p) >= 0.5 && switch_ref == kInfinity) switch_ref = sdist;
  }
  ASSERT_LT(switch_ref, 0.6) << "the reference never reaches opacity 0.5";
  ASSERT_LT(switch_map, 0.6) << "the map never shadows";
  EXPECT_NEAR(switch_map, switch_ref + bias, delta + spacing);
}

// Receivers on a line below a ball (step TF, opacity a chosen so that 0.5 is reached on a chord of r),
// crossing the edge of its shadow sideways, at the centres of one texel row of the map. The map's switch
// sits on a texel border, within half a texel of where the reference (the receiver's own light ray)
// crosses 0.5; the two rays' lattices differ, moving each of the ball's two boundaries by up to Δ/2, i.e.
// the chord by Δ, which moves the crossing by Δ/|dchord/dx| (dchord/dx = 2x/√(r² − x²) = 2√3 at the
// crossing x = r√3/2); receivers are texel/8 apart. Tolerance: texel/2 + Δ/(2√3) + texel/8.
TEST(ShadowsClassicMap, SwitchesWhereOpacityCrossesHalfAcrossTheShadowEdge) {
  const int size = 64;
  const double r = 0.3, h = 1.0 / (size - 1);
  const double a = 1 - std::pow(0.5, h / r);
  MediumHolder m(volume_scene({{"name", "sphere"}, {"size", size}, {"radius", r}}, step_tf(a)));
  const Light light{LightType::Directional, {}, unit(0, -1, 0)};
  ShadowSettings s;
  s.technique = "shadow_map";
  s.params.set("resolution", 128);
  const auto map = build_technique(s, *m.medium, light);
  const LightProjection& proj = dynamic_cast<const ClassicShadowMap&>(*map).projection();
  const float texel = proj.texel_size(1, static_cast<int>(param_integer(TechniqueFamily::Shadow, s.params, "resolution")));
  // The light-space axis that moves across the row, and a texel-centre row through the ball's centre.
  float u0, v0, d0;
  ASSERT_TRUE(proj.project({0, -0.42f, 0}, u0, v0, d0));
  const float n = static_cast<float>(static_cast<int>(param_integer(TechniqueFamily::Shadow, s.params, "resolution")));
  const float v_centre = (std::floor(v0 * n) + 0.5f) / n;
  std::vector<std::pair<double, bool>> line;  // (u, lit) of the map and of the reference
  double switch_map = -1, switch_ref = -1;
  const int steps = 8 * static_cast<int>(param_integer(TechniqueFamily::Shadow, s.params, "resolution")) / 2;
  for (int i = 0; i <= steps; ++i) {
    const float u = 0.5f + 0.5f * static_cast<float>(i) / static_cast<float>(steps);  // from the centre outwards
    const Ray ray = proj.texel_ray(u, v_centre);
    const Vec3 p = ray.at(d0);
    const bool lit_map = transmittance_at(*map, p).r > 0.5f;
    const bool lit_ref = accumulated_opacity(*m.medium, light, p) < 0.5;
    const double x = std::sqrt(p.x * p.x + p.z * p.z);  // distance from the ball's axis
    if (lit_map && switch_map < 0) switch_map = x;
    if (lit_ref && switch_ref < 0) switch_ref = x;
    if (!lit_map && switch_map >= 0) ADD_FAILURE() << "shadowed again at x = " << x;
  }
  ASSERT_GT(switch_ref, 0.2);
  ASSERT_GT(switch_map, 0.2);
  const double tolerance = texel / 2 + m.medium->step() / (2 * std::sqrt(3.0)) + texel / 8;
  EXPECT_NEAR(switch_map, switch_ref, tolerance) << "texel " << texel;
  EXPECT_NEAR(switch_ref, r * std::sqrt(3.0) / 2, 1.5 * h) << "the reference crossing is where the chord is r";
}

// ---------------------------------------------------------------------------------------------------
// 7. Light projection.

// project(texel_ray(u, v).at(t)) = (u, v, t): map coordinates and depth are consistent for both kinds of
// light. Tolerance: a handful of float operations on values of order 1–5 give errors of order 1e-6;
// 1e-5 (u, v) and 1e-5·t (depth) leave a margin of 10 and still catch a half-texel slip at 16384².
TEST(ShadowsLightProjection, RoundTrip) {
  const Box3 bounds{{-0.5f, -0.4f, -0.6f}, {0.7f, 0.5f, 0.4f}};
  const std::vector<Light> lights{Light{LightType::Directional, {}, unit(0.3f, -1, 0.2f)},
                                  Light{LightType::Directional, {}, unit(0, -1, 0)},
                                  Light{LightType::Point, {0.7f, 1.6f, 0.9f}},
                                  Light{LightType::Spot, {-2.5f, 0.3f, 1.0f}, unit(1, -0.1f, -0.4f)}};
  for (const Light& light : lights) {
    SCOPED_TRACE(to_string(light.type));
    const LightProjection p = LightProjection::fit(light, bounds);
    EXPECT_EQ(p.perspective(), light.type != LightType::Directional);
    EXPECT_LT(p.near_depth(), p.far_depth());
    for (int i = 0; i < 50; ++i) {
      const float u = uniform_float(41, i, 0), v = uniform_float(41, i, 1);
      const float t = p.near_depth() + (p.far_depth() - p.near_depth()) * uniform_float(41, i, 2);
      const Vec3 x = p.texel_ray(u, v).at(t);
      float u2, v2, t2;
      ASSERT_TRUE(p.project(x, u2, v2, t2));
      EXPECT_NEAR(u2, u, 1e-5);
      EXPECT_NEAR(v2, v, 1e-5);
      EXPECT_NEAR(t2, t, 1e-5 * std::max(1.0f, t));
    }
    // Every corner of the bounds is inside the map, in front of the light, within [near, far].
    for (int c = 0; c < 8; ++c) {
      float u, v, d;
      ASSERT_TRUE(p.project(bounds.corner(c), u, v, d)) << "corner " << c;
      EXPECT_GE(d, p.near_depth() - 1e-5f);
      EXPECT_LE(d, p.far_depth() + 1e-5f);
    }
  }
}

TEST(ShadowsLightProjection, LightInsideTheBoundsIsAnError) {
  const Box3 bounds{{-0.5f, -0.5f, -0.5f}, {0.5f, 0.5f, 0.5f}};
  EXPECT_THROW(LightProjection::fit(Light{LightType::Point, {0.1f, 0.2f, 0.0f}}, bounds), Error);
  EXPECT_THROW(LightProjection::fit(Light{LightType::Spot, {0, 0, 0}, unit(0, -1, 0)}, bounds), Error);
  // On the surface of the (padded) box, and so close that the frustum would need more than 80°.
  EXPECT_THROW(LightProjection::fit(Light{LightType::Point, {0, 0.52f, 0}}, bounds), Error);
  EXPECT_NO_THROW(LightProjection::fit(Light{LightType::Point, {0, 3, 0}}, bounds));
  // Through a shadow map's build as well, with a message that points to ray_traced.
  MediumHolder m(full_box_scene(16, constant_tf(0.05)));
  ShadowSettings s;
  s.technique = "cssm";
  s.params.set("resolution", 16);
  auto t = make_shadow_technique(s);
  try {
    t->build(*m.medium, Light{LightType::Point, {0.1f, 0.1f, 0.1f}});
    ADD_FAILURE() << "no error for a point light inside the volume";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("ray_traced"), std::string::npos) << e.what();
  }
}
