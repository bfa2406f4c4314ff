// Tests for procedural.h: grid layout, the analytic shapes measured by counting voxels, the
// Marschner-Lobb signal at analytic points, the test-spheres plateaus and their preset colours, the
// "ct-body" CT (its grid, determinism, tissues at known places, many bone components, its noise), and
// the validation of specs.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <map>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/data/ct_body.h"
#include "penumbra/data/procedural.h"
#include "penumbra/data/transfer_function.h"

using namespace penumbra;
using nlohmann::json;

namespace {

std::string procedural_error_of(const json& spec) {
  try {
    make_procedural_volume(spec);
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected a penumbra::Error for " << spec.dump();
  return "";
}

}  // namespace

TEST(Procedural, EveryNameBuildsOnTheDocumentedGrid) {
  const auto names = procedural_volume_names();
  ASSERT_EQ(names.size(), 7u);
  for (const std::string& name : names) {
    if (name == "ct-body") continue;  // a grid of its own: the ProceduralCtBody tests
    if (name == "molecular-density") continue;  // needs a molecule file: test_molecular_density.cpp
    const Volume v = make_procedural_volume(json{{"name", name}, {"size", 17}});
    EXPECT_EQ(v.type(), ScalarType::Float32) << name;
    EXPECT_EQ(v.dims(), (std::array<int, 3>{17, 17, 17})) << name;
    for (int a = 0; a < 3; ++a) {
      EXPECT_FLOAT_EQ(v.spacing()[a], 1.0f / 16.0f) << name;
      EXPECT_FLOAT_EQ(v.origin()[a], -0.5f) << name;
      EXPECT_NEAR(v.bounds().hi[a], 0.5f, 1e-6f) << name;
    }
    EXPECT_GE(v.min_value(), 0.0f) << name;
    EXPECT_LE(v.max_value(), 1.0f + 1e-6f) << name;
    EXPECT_GT(v.max_value(), v.min_value()) << name;
  }
  EXPECT_EQ(make_procedural_volume(json{{"name", "sphere"}}).dims()[0], 64);  // default size
}

TEST(Procedural, SlabThicknessByCountingVoxels) {
  for (const double thickness : {0.3, 0.1, 0.55}) {
    const Volume v = make_procedural_volume(json{{"name", "slab"}, {"size", 65}, {"thickness", thickness}});
    const float h = v.spacing().y;
    int rows = 0;
    for (int j = 0; j < 65; ++j) {
      const float row = v.value(0, j, 0);
      ASSERT_TRUE(row == 0.0f || row == 1.0f);
      for (int k = 0; k < 65; k += 8)
        for (int i = 0; i < 65; i += 8) ASSERT_EQ(v.value(i, j, k), row);  // independent of x and z
      EXPECT_EQ(row, v.value(0, 64 - j, 0));                              // centred on y = 0
      rows += row > 0 ? 1 : 0;
    }
    EXPECT_NEAR(static_cast<float>(rows) * h, thickness, h) << thickness;
  }
  // Default thickness 0.3 at size 64 too.
  const Volume d = make_procedural_volume(json{{"name", "slab"}});
  int rows = 0;
  for (int j = 0; j < 64; ++j) rows += d.value(10, j, 20) > 0 ? 1 : 0;
  EXPECT_NEAR(static_cast<float>(rows) * d.spacing().y, 0.3f, d.spacing().y);
}

TEST(Procedural, SphereVolumeMatchesWithinSurfaceVoxels) {
  for (const double radius : {0.3, 0.12}) {
    const int n = 81;
    const Volume v = make_procedural_volume(json{{"name", "sphere"}, {"size", n}, {"radius", radius}});
    const double h = v.spacing().x;
    long inside = 0, surface = 0;
    for (int k = 0; k < n; ++k)
      for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
          if (v.value(i, j, k) == 0.0f) continue;
          ++inside;
          // A surface voxel has a 6-neighbour outside the ball (the sphere never touches the border).
          if (v.value(i - 1, j, k) == 0 || v.value(i + 1, j, k) == 0 || v.value(i, j - 1, k) == 0 ||
              v.value(i, j + 1, k) == 0 || v.value(i, j, k - 1) == 0 || v.value(i, j, k + 1) == 0)
            ++surface;
        }
    const double expected = 4.0 / 3.0 * 3.14159265358979 * radius * radius * radius / (h * h * h);
    ASSERT_GT(surface, 0);
    // Only voxels of the surface layer can be misclassified, and their errors mostly cancel: a tenth
    // of the layer is a safe bound (measured: 129 of 5838 voxels at r 0.3, 37 of 894 at r 0.12).
    EXPECT_NEAR(static_cast<double>(inside), expected, 0.1 * static_cast<double>(surface)) << radius;
    EXPECT_EQ(v.value(n / 2, n / 2, n / 2), 1.0f);
    EXPECT_EQ(v.value(0, 0, 0), 0.0f);
  }
}

TEST(Procedural, HollowSphereIsAShell) {
  const Volume v = make_procedural_volume(json{{"name", "hollow-sphere"}, {"size", 81}});  // r 0.35, t 0.08
  // Voxel 40 + 80 x lies at x; the shell holds 0.27 <= r <= 0.35.
  EXPECT_EQ(v.value(40, 40, 40), 0.0f);
  EXPECT_EQ(v.value(40 + 16, 40, 40), 0.0f);  // r = 0.2
  EXPECT_EQ(v.value(40 + 24, 40, 40), 1.0f);  // r = 0.3
  EXPECT_EQ(v.value(40, 40 - 24, 40), 1.0f);
  EXPECT_EQ(v.value(40 + 32, 40, 40), 0.0f);  // r = 0.4
  const Volume thin = make_procedural_volume(json{{"name", "hollow-sphere"}, {"size", 81}, {"radius", 0.2}, {"thickness", 0.05}});
  EXPECT_EQ(thin.value(40 + 16, 40, 40), 1.0f);
  EXPECT_EQ(thin.value(40 + 8, 40, 40), 0.0f);
}

TEST(Procedural, MarschnerLobbAtAnalyticPoints) {
  // size 41: voxel 20 is the centre, voxel 0 and 40 the faces (signal coordinates -1 and 1).
  const Volume v = make_procedural_volume(json{{"name", "marschner-lobb"}, {"size", 41}});
  // Centre: r = 0 so rho_r = cos(2 pi 6) = 1; rho = (1 + 2 alpha) / (2 (1 + alpha)) = 0.6.
  EXPECT_NEAR(v.value(20, 20, 20), 0.6f, 1e-5f);
  EXPECT_NEAR(v.value(20, 20, 40), 0.2f, 1e-5f);  // z = 1: sin = 1
  EXPECT_NEAR(v.value(20, 20, 0), 1.0f, 1e-5f);   // z = -1: sin = -1
  EXPECT_NEAR(v.value(40, 20, 20), 0.6f, 1e-5f);  // r = 1: cos(pi/2) = 0, rho_r = 1
  // Anywhere, against the formula written out independently.
  const double pi = 3.14159265358979323846, alpha = 0.25, fm = 6;
  for (const auto& [i, j, k] : {std::array<int, 3>{30, 12, 7}, std::array<int, 3>{5, 33, 21}, std::array<int, 3>{17, 26, 38}}) {
    const double x = -1 + i / 20.0, y = -1 + j / 20.0, z = -1 + k / 20.0;
    const double rr = std::cos(2 * pi * fm * std::cos(pi * std::hypot(x, y) / 2));
    EXPECT_NEAR(v.value(i, j, k), (1 - std::sin(pi * z / 2) + alpha * (1 + rr)) / (2 * (1 + alpha)), 1e-5);
  }
  // Parameters: with alpha = 0 the signal is the z ramp alone.
  const Volume ramp = make_procedural_volume(json{{"name", "marschner-lobb"}, {"size", 41}, {"alpha", 0}, {"fm", 3}});
  EXPECT_NEAR(ramp.value(7, 31, 30), (1 - std::sin(pi * 0.5 / 2)) / 2, 1e-5);
}

TEST(Procedural, TestSpheresHaveDistinctPlateausInDistinctColours) {
  const Volume v = make_procedural_volume(json{{"name", "test-spheres"}, {"size", 96}});
  std::map<float, long> histogram;
  long ramp = 0;
  for (std::size_t i = 0; i < v.voxel_count(); ++i) histogram[v.value(i)] += 1;
  std::vector<float> plateaus;
  for (const auto& [value, count] : histogram) {
    if (value > 0 && count >= 200) plateaus.push_back(value);
    if (count < 50) ramp += count;
  }
  ASSERT_GE(plateaus.size(), 4u);
  for (std::size_t a = 1; a < plateaus.size(); ++a) EXPECT_GE(plateaus[a] - plateaus[a - 1], 0.1f);
  EXPECT_GT(ramp, 1000);  // smoothed edges: many voxels between the plateaus
  EXPECT_EQ(v.value(0, 0, 0), 0.0f);  // a margin of empty space
  EXPECT_EQ(v.value(95, 95, 95), 0.0f);

  // The preset gives every plateau a visible, clearly different colour, and hides values between them.
  const TransferFunction tf = parse_transfer_function(json{{"preset", "test-spheres"}}, v.min_value(), v.max_value(), "");
  for (std::size_t a = 0; a < plateaus.size(); ++a) {
    const Rgba ca = tf.evaluate(plateaus[a]);
    EXPECT_GT(ca.a, 0.0f) << plateaus[a];
    EXPECT_LT(ca.a, 1.0f) << plateaus[a];  // partly transparent, for coloured shadows
    if (a > 0) {
      EXPECT_EQ(tf.evaluate(0.5f * (plateaus[a] + plateaus[a - 1])).a, 0.0f);
    }
    for (std::size_t b = 0; b < a; ++b) {
      const Rgba cb = tf.evaluate(plateaus[b]);
      const float diff = std::max({std::abs(ca.rgb.r - cb.rgb.r), std::abs(ca.rgb.g - cb.rgb.g), std::abs(ca.rgb.b - cb.rgb.b)});
      EXPECT_GT(diff, 0.3f) << plateaus[a] << " vs " << plateaus[b];
    }
  }
}

TEST(Procedural, TestSpheresSeedIsDeterministic) {
  const Volume fixed = make_procedural_volume(json{{"name", "test-spheres"}, {"size", 32}});
  const Volume a = make_procedural_volume(json{{"name", "test-spheres"}, {"size", 32}, {"seed", 3}});
  const Volume b = make_procedural_volume(json{{"name", "test-spheres"}, {"size", 32}, {"seed", 3}});
  long same = 0, differ = 0;
  for (std::size_t i = 0; i < a.voxel_count(); ++i) {
    same += a.value(i) == b.value(i);
    differ += a.value(i) != fixed.value(i);
  }
  EXPECT_EQ(same, static_cast<long>(a.voxel_count()));
  EXPECT_GT(differ, 100);
}

TEST(Procedural, BadSpecsAreErrors) {
  const std::string unknown = procedural_error_of(json{{"name", "cube"}});
  EXPECT_NE(unknown.find("cube"), std::string::npos) << unknown;
  for (const std::string& n : procedural_volume_names()) EXPECT_NE(unknown.find(n), std::string::npos) << unknown;
  EXPECT_NE(procedural_error_of(json{{"name", "sphere"}, {"size", 0}}).find("size"), std::string::npos);
  EXPECT_NE(procedural_error_of(json{{"name", "sphere"}, {"size", 5000}}).find("5000"), std::string::npos);
  procedural_error_of(json{{"name", "sphere"}, {"size", 1}});
  procedural_error_of(json{{"name", "sphere"}, {"size", 2.5}});
  procedural_error_of(json{{"name", "sphere"}, {"size", "64"}});
  const std::string key = procedural_error_of(json{{"name", "slab"}, {"radius", 0.2}});  // radius is not a slab parameter
  EXPECT_NE(key.find("radius"), std::string::npos) << key;
  const std::string neg = procedural_error_of(json{{"name", "sphere"}, {"radius", -0.1}});
  EXPECT_NE(neg.find("radius"), std::string::npos) << neg;
  EXPECT_NE(neg.find("-0.1"), std::string::npos) << neg;
  procedural_error_of(json{{"name", "sphere"}, {"radius", "big"}});
  procedural_error_of(json{{"name", "slab"}, {"thickness", 0}});
  procedural_error_of(json{{"name", "hollow-sphere"}, {"radius", 0.2}, {"thickness", 0.3}});
  procedural_error_of(json{{"name", "marschner-lobb"}, {"alpha", -1}});
  procedural_error_of(json{{"name", "test-spheres"}, {"seed", -2}});
  procedural_error_of(json{{"size", 32}});
  procedural_error_of(json{{"name", 3}});
  procedural_error_of(json::array());
}

// ---------------------------------------------------------------- ct-body

namespace {

// The nearest voxel's value at x, y (mm) and the height h above the box's bottom (world z = h - 867).
float ct_value(const Volume& v, double x, double y, double h) {
  const Vec3 p = v.to_voxel(Vec3(static_cast<float>(x), static_cast<float>(y), static_cast<float>(h - 867)));
  const auto clamp_axis = [&](float c, int a) { return std::clamp(static_cast<int>(std::lround(c)), 0, v.dims()[a] - 1); };
  return v.value(clamp_axis(p.x, 0), clamp_axis(p.y, 1), clamp_axis(p.z, 2));
}

// The largest value on the segment from (x0, y, h) to (x1, y, h), sampled every 0.5 mm.
float ct_max_along_x(const Volume& v, double x0, double x1, double y, double h) {
  float m = 0;
  for (double x = x0; x <= x1; x += 0.5) m = std::max(m, ct_value(v, x, y, h));
  return m;
}

// A ~4 mm body without noise, shared by the tests that read tissues and count bones.
const Volume& quiet_body() {
  static const Volume v = make_procedural_volume(json{{"name", "ct-body"}, {"dims", {128, 128, 434}}, {"noise", 0}});
  return v;
}

// Connected components (6-neighbourhood) of the voxels at or above `threshold`, by flood fill.
int components_above(const Volume& v, float threshold) {
  const auto [nx, ny, nz] = v.dims();
  std::vector<std::uint8_t> seen(v.voxel_count(), 0);
  std::vector<std::size_t> stack;
  int count = 0;
  for (std::size_t start = 0; start < v.voxel_count(); ++start) {
    if (seen[start] || v.value(start) < threshold) continue;
    ++count;
    seen[start] = 1;
    stack.push_back(start);
    while (!stack.empty()) {
      const std::size_t idx = stack.back();
      stack.pop_back();
      const int i = static_cast<int>(idx % static_cast<std::size_t>(nx));
      const int j = static_cast<int>(idx / static_cast<std::size_t>(nx) % static_cast<std::size_t>(ny));
      const int k = static_cast<int>(idx / (static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny)));
      const std::array<std::array<int, 3>, 6> steps{{{-1, 0, 0}, {1, 0, 0}, {0, -1, 0}, {0, 1, 0}, {0, 0, -1}, {0, 0, 1}}};
      for (const auto& d : steps) {
        const int a = i + d[0], b = j + d[1], c = k + d[2];
        if (a < 0 || b < 0 || c < 0 || a >= nx || b >= ny || c >= nz) continue;
        const std::size_t n = v.index(a, b, c);
        if (!seen[n] && v.value(n) >= threshold) seen[n] = 1, stack.push_back(n);
      }
    }
  }
  return count;
}

}  // namespace

TEST(ProceduralCtBody, GridIsTheDocumentedBox) {
  const Volume v = make_procedural_volume(json{{"name", "ct-body"}, {"dims", {64, 48, 200}}});
  EXPECT_EQ(v.type(), ScalarType::UInt16);
  EXPECT_EQ(v.dims(), (std::array<int, 3>{64, 48, 200}));
  EXPECT_FLOAT_EQ(v.spacing().x, 500.0f / 64);
  EXPECT_FLOAT_EQ(v.spacing().y, 500.0f / 48);
  EXPECT_FLOAT_EQ(v.spacing().z, 1734.0f / 200);
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(v.bounds().lo[a] + v.bounds().hi[a], 0.0f, 1e-3f) << a;  // centred
  EXPECT_NEAR(v.bounds().hi.z - v.bounds().lo.z, 1734.0f * 199 / 200, 1e-2f);
  EXPECT_EQ(CtBodyParams{}.dims, (std::array<int, 3>{512, 512, 1734}));  // the Visible Woman's grid by default
}

TEST(ProceduralCtBody, SameForASeedAndAnyThreadCount) {
  const json spec{{"name", "ct-body"}, {"dims", {64, 64, 200}}, {"seed", 3}};
  const auto build = [](const json& s, int threads) {
    ThreadLimit limit(threads);
    return make_procedural_volume(s);
  };
  // Also a slice whose voxel count is odd: the noise hashes 4 voxels at a time across slice borders.
  for (const json& s : {spec, json{{"name", "ct-body"}, {"dims", {9, 11, 13}}}}) {
    const Volume one = build(s, 1), two = build(s, 2);
    ASSERT_EQ(one.memory_bytes(), two.memory_bytes());
    EXPECT_EQ(std::memcmp(one.data(), two.data(), one.memory_bytes()), 0) << s.dump();
  }
  const Volume one = build(spec, 1);
  const Volume again = make_procedural_volume(spec);
  EXPECT_EQ(std::memcmp(one.data(), again.data(), one.memory_bytes()), 0);
  json other = spec;
  other["seed"] = 4;
  const Volume reseeded = make_procedural_volume(other);
  std::size_t differ = 0;
  for (std::size_t i = 0; i < one.voxel_count(); ++i) differ += one.value(i) != reseeded.value(i);
  EXPECT_GT(differ, one.voxel_count() / 2);  // the noise differs almost everywhere
}

TEST(ProceduralCtBody, TissuesAtKnownPlaces) {
  using namespace ct_tissue;
  const Volume& v = quiet_body();
  // Without noise a tissue is within 3% (the low-frequency texture) of its value.
  const auto within = [](float value, float tissue) { return std::abs(value - tissue) <= 0.031f * tissue + 1; };
  for (const double h : {100.0, 900.0, 1700.0}) {
    EXPECT_TRUE(within(ct_value(v, -240, -240, h), kAir)) << h;  // a corner of the box
    EXPECT_TRUE(within(ct_value(v, 0, 240, h), kAir)) << h;      // in front of the body
  }
  // The skull on the head's left-right axis (centre (0, 0, 1598) mm, outer semi-axis 72): bone in the
  // shell, brain inside, air outside.
  EXPECT_GE(ct_max_along_x(v, 60, 76, 0, 1598), kBoneThreshold);
  EXPECT_TRUE(within(ct_value(v, 0, 0, 1598), kSoft)) << ct_value(v, 0, 0, 1598);
  EXPECT_TRUE(within(ct_value(v, 20, -20, 1640), kSoft)) << ct_value(v, 20, -20, 1640);
  EXPECT_TRUE(within(ct_value(v, 100, 0, 1598), kAir));
  // The abdomen: liver (centre (-45, 12, 1090)); the right lung (centre (-64, -4, 1240)) is air-like.
  EXPECT_TRUE(within(ct_value(v, -45, 12, 1090), kOrgan)) << ct_value(v, -45, 12, 1090);
  int airy = 0;
  for (int a = -2; a <= 2; ++a)
    for (int b = -2; b <= 2; ++b)
      for (int c = -2; c <= 2; ++c) airy += ct_value(v, -64 + 8 * a, -4 + 8 * b, 1240 + 8 * c) < 600;
  EXPECT_GT(airy, 100) << "of 125";  // a few lung vessels are soft tissue
  // The left thigh at 700 mm: subcutaneous fat under the skin, a femur of cortex around marrow.
  EXPECT_TRUE(within(ct_value(v, 80, -59.5, 700), kFat)) << ct_value(v, 80, -59.5, 700);  // 2 + 7 mm deep
  EXPECT_GE(ct_max_along_x(v, 100, 115, 5.9, 700), kBoneThreshold);
  EXPECT_TRUE(within(ct_value(v, 96.7, 5.9, 700), kCancellous)) << ct_value(v, 96.7, 5.9, 700);
  EXPECT_LE(v.max_value(), kEnamel * 1.03f + 1);
  EXPECT_GE(v.min_value(), kAir * 0.97f - 1);
}

TEST(ProceduralCtBody, BoneIsManySeparateComponents) {
  const Volume& v = quiet_body();
  const int bones = components_above(v, ct_tissue::kBoneThreshold);
  std::printf("[ bones    ] %d components >= %g at 128 x 128 x 434\n", bones, ct_tissue::kBoneThreshold);
  // Vertebrae, ribs, phalanges, teeth and calcifications: far more than the long bones.
  EXPECT_GT(bones, 100);
}

TEST(ProceduralCtBody, NoiseHasTheRequestedDeviation) {
  const json spec{{"name", "ct-body"}, {"dims", {64, 64, 200}}, {"seed", 9}};
  json quiet = spec;
  quiet["noise"] = 0;
  const Volume noisy = make_procedural_volume(spec), clean = make_procedural_volume(quiet);
  double sum = 0, sum2 = 0;
  std::size_t n = 0;
  for (std::size_t i = 0; i < clean.voxel_count(); ++i) {
    if (clean.value(i) < 500) continue;  // inside the body, where clamping at 0 does not cut the noise
    const double d = noisy.value(i) - clean.value(i);
    sum += d;
    sum2 += d * d;
    ++n;
  }
  ASSERT_GT(n, 100000u);
  const double mean = sum / static_cast<double>(n), sd = std::sqrt(sum2 / static_cast<double>(n) - mean * mean);
  EXPECT_NEAR(mean, 0, 0.5);
  EXPECT_NEAR(sd, 60, 1.5);  // the default noise
}

// What `penumbra convert` streams a ct-body larger than memory from: any slab of slices is byte for byte
// the whole volume's (the noise hashes 4 voxels at a time across slice borders: odd slices test that).
TEST(ProceduralCtBody, SlabsAreTheWholeVolumesSlices) {
  for (const CtBodyParams p : {CtBodyParams{{48, 40, 90}, 2, 60}, CtBodyParams{{9, 11, 13}, 1, 60}}) {
    const Volume whole = make_ct_body_volume(p);
    const std::size_t slice = static_cast<std::size_t>(p.dims[0]) * p.dims[1];
    CtBodySlices slices(p);  // one maker for every slab, in any order
    for (const auto& [first, count] : std::vector<std::pair<int, int>>{{0, 1}, {3, 5}, {p.dims[2] - 2, 2}, {0, p.dims[2]}}) {
      std::vector<std::uint16_t> slab(slice * static_cast<std::size_t>(count));
      slices.make(first, count, slab.data());
      EXPECT_EQ(std::memcmp(slab.data(), whole.data_as<std::uint16_t>() + slice * static_cast<std::size_t>(first), slab.size() * 2), 0)
          << "slices " << first << " + " << count << " of " << p.dims[2];
    }
    std::vector<std::uint16_t> one(slice);
    EXPECT_THROW(slices.make(p.dims[2], 1, one.data()), Error);
    const CtBodyGrid g = ct_body_grid(p);
    EXPECT_FLOAT_EQ(static_cast<float>(g.spacing[2]), whole.spacing().z);
    EXPECT_FLOAT_EQ(static_cast<float>(g.origin[0]), whole.origin().x);
  }
  // convert takes dims beyond what a volume held whole may have; a scene keeps 2048
  EXPECT_EQ(ct_body_params(json{{"name", "ct-body"}, {"dims", {4096, 4096, 2048}}}, 16384).dims, (std::array<int, 3>{4096, 4096, 2048}));
  EXPECT_THROW(ct_body_params(json{{"name", "ct-body"}, {"dims", {4096, 4096, 2048}}}), Error);
  EXPECT_THROW(ct_body_params(json{{"name", "ct-body"}, {"size", 64}}, 16384), Error);
}

TEST(ProceduralCtBody, BadParametersNameTheKey) {
  const auto expect_key = [](const json& spec, const std::string& key) {
    const std::string e = procedural_error_of(spec);
    EXPECT_NE(e.find("\"" + key + "\""), std::string::npos) << e;
    EXPECT_NE(e.find("ct-body"), std::string::npos) << e;
  };
  const json base{{"name", "ct-body"}, {"dims", {16, 16, 16}}};
  for (const json& dims : {json{16, 16}, json{7, 16, 16}, json{16, 16, 2049}, json{16.5, 16, 16}, json("16"), json{16, "a", 16}}) {
    json spec = base;
    spec["dims"] = dims;
    expect_key(spec, "dims");
  }
  json spec = base;
  spec["size"] = 64;  // the other shapes' cube size does not apply
  expect_key(spec, "size");
  for (const json& seed : {json(-1), json(1.5), json("x")}) {
    spec = base;
    spec["seed"] = seed;
    expect_key(spec, "seed");
  }
  for (const json& noise : {json(-1), json("loud"), json(1e5)}) {
    spec = base;
    spec["noise"] = noise;
    expect_key(spec, "noise");
  }
  spec = base;
  spec["radius"] = 3;
  const std::string unknown = procedural_error_of(spec);
  EXPECT_NE(unknown.find("radius"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("dims"), std::string::npos) << unknown;  // lists what is accepted
  EXPECT_EQ(unknown.find("size"), std::string::npos) << unknown;
}
