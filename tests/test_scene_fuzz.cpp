// Fuzzing the scene reader: every value of a valid scene (and every key) is replaced, one at a time and
// then several at once, by values of the wrong type, out of range, NaN-like, huge or empty. The reader
// must either build a scene or throw penumbra::Error — never a crash, never a library exception such as
// nlohmann::json::type_error that would reach the user without the key's name.
#include <gtest/gtest.h>

#include <functional>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/rng.h"
#include "penumbra/scene_io/scene_file.h"

using namespace penumbra;

namespace {

nlohmann::json fuzzed_base_scene() {
  return nlohmann::json::parse(R"({
    "volumes": [ { "procedural": { "name": "test-spheres", "size": 12 },
                   "transfer_function": { "points": [[0, 0, 0, 0, 0], [1, 1, 0.5, 0.2, 0.3]], "opacity_scale": 1 },
                   "shadow_transfer_function": { "preset": "test-spheres" }, "step": 0.5, "jitter": true } ],
    "planes": [ { "point": [0, -0.6, 0], "normal": [0, 1, 0], "color": [0.9, 0.9, 0.9], "size": 3 } ],
    "lights": [ { "type": "spot", "position": [1, 2, 1], "direction": [-1, -2, -1], "angle_deg": 30, "softness": 0.2,
                  "color": [1, 1, 1], "intensity": 1 } ],
    "camera": { "eye": [2, 1.5, 2], "target": [0, 0, 0], "up": [0, 1, 0], "fov_deg": 35, "width": 8, "height": 8 },
    "shadows": { "technique": "cssm", "resolution": 32, "offsets": 13, "seed": 1, "nodes": 3, "pcf": 0, "bias": -1, "step": -1 },
    "ambient": { "technique": "none" },
    "shading": { "ambient": 0.2, "diffuse": 0.8, "specular": 0.25, "shininess": 32 },
    "background": [0.1, 0.1, 0.1]
  })");
}

const std::vector<nlohmann::json>& replacements() {
  static const std::vector<nlohmann::json> r = {
      nullptr, true, 0, -1, 1e300, -1e300, 2147483648LL, 0.5, "", "x", "nan", nlohmann::json::array(),
      nlohmann::json::array({1, 2}), nlohmann::json::array({1, 2, 3}), nlohmann::json::array({"a", "b", "c"}),
      nlohmann::json::object(), nlohmann::json::object({{"unknown", 1}}), nlohmann::json::array({nlohmann::json::array()})};
  return r;
}

// Every JSON pointer to a value inside j.
void collect_pointers(const nlohmann::json& j, const nlohmann::json::json_pointer& at, std::vector<nlohmann::json::json_pointer>& out) {
  out.push_back(at);
  if (j.is_object())
    for (auto it = j.begin(); it != j.end(); ++it) collect_pointers(it.value(), at / it.key(), out);
  else if (j.is_array())
    for (std::size_t i = 0; i < j.size(); ++i) collect_pointers(j[i], at / i, out);
}

void expect_error_or_scene(const nlohmann::json& j, const std::string& what) {
  try {
    const Scene s = build_scene(j, "");
    EXPECT_GT(s.camera.width, 0) << what;
  } catch (const Error&) {
    // the expected way to refuse
  } catch (const std::exception& e) {
    ADD_FAILURE() << what << ": escaped as " << typeid(e).name() << ": " << e.what();
  }
}

}  // namespace

TEST(SceneFileFuzz, EverySingleReplacementIsBuiltOrRefused) {
  const nlohmann::json base = fuzzed_base_scene();
  ASSERT_NO_THROW(build_scene(base, ""));
  std::vector<nlohmann::json::json_pointer> pointers;
  collect_pointers(base, nlohmann::json::json_pointer(), pointers);
  int refused = 0, built = 0;
  for (const auto& p : pointers) {
    if (p.empty()) continue;
    for (const auto& value : replacements()) {
      nlohmann::json j = base;
      j[p] = value;
      try {
        build_scene(j, "");
        ++built;
      } catch (const Error&) {
        ++refused;
      } catch (const std::exception& e) {
        ADD_FAILURE() << p.to_string() << " = " << value.dump() << ": escaped as " << e.what();
      }
    }
  }
  EXPECT_GT(refused, 500);  // most replacements are wrong and must be named
  EXPECT_GT(built, 10);     // and some are valid (e.g. a different number in range)
}

TEST(SceneFileFuzz, RandomMultipleReplacementsAreBuiltOrRefused) {
  const nlohmann::json base = fuzzed_base_scene();
  std::vector<nlohmann::json::json_pointer> pointers;
  collect_pointers(base, nlohmann::json::json_pointer(), pointers);
  const auto& values = replacements();
  for (std::uint64_t trial = 0; trial < 400; ++trial) {
    nlohmann::json j = base;
    for (std::uint64_t m = 0; m < 3; ++m) {
      const auto& p = pointers[1 + static_cast<std::size_t>(uniform_float(9, trial, m, 0) * static_cast<float>(pointers.size() - 1))];
      const auto& v = values[static_cast<std::size_t>(uniform_float(9, trial, m, 1) * static_cast<float>(values.size()))];
      try {
        j[p] = v;  // the path may have vanished under an earlier replacement
      } catch (const std::exception&) {
      }
    }
    expect_error_or_scene(j, "trial " + std::to_string(trial));
  }
}
