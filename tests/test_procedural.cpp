// Tests for procedural.h: grid layout, the analytic shapes measured by counting voxels, the
// Marschner-Lobb signal at analytic points, the test-spheres plateaus and their preset colours, and
// the validation of specs.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <map>
#include <string>

#include "penumbra/core/error.h"
#include "penumbra/data/procedural.h"
#include "penumbra/data/transfer_function.h"

using namespace penumbra;
using nlohmann::json;

namespace {

std::string error_of(const json& spec) {
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
  ASSERT_EQ(names.size(), 5u);
  for (const std::string& name : names) {
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
  const std::string unknown = error_of(json{{"name", "cube"}});
  EXPECT_NE(unknown.find("cube"), std::string::npos) << unknown;
  for (const std::string& n : procedural_volume_names()) EXPECT_NE(unknown.find(n), std::string::npos) << unknown;
  EXPECT_NE(error_of(json{{"name", "sphere"}, {"size", 0}}).find("size"), std::string::npos);
  EXPECT_NE(error_of(json{{"name", "sphere"}, {"size", 5000}}).find("5000"), std::string::npos);
  error_of(json{{"name", "sphere"}, {"size", 1}});
  error_of(json{{"name", "sphere"}, {"size", 2.5}});
  error_of(json{{"name", "sphere"}, {"size", "64"}});
  const std::string key = error_of(json{{"name", "slab"}, {"radius", 0.2}});  // radius is not a slab parameter
  EXPECT_NE(key.find("radius"), std::string::npos) << key;
  const std::string neg = error_of(json{{"name", "sphere"}, {"radius", -0.1}});
  EXPECT_NE(neg.find("radius"), std::string::npos) << neg;
  EXPECT_NE(neg.find("-0.1"), std::string::npos) << neg;
  error_of(json{{"name", "sphere"}, {"radius", "big"}});
  error_of(json{{"name", "slab"}, {"thickness", 0}});
  error_of(json{{"name", "hollow-sphere"}, {"radius", 0.2}, {"thickness", 0.3}});
  error_of(json{{"name", "marschner-lobb"}, {"alpha", -1}});
  error_of(json{{"name", "test-spheres"}, {"seed", -2}});
  error_of(json{{"size", 32}});
  error_of(json{{"name", 3}});
  error_of(json::array());
}
