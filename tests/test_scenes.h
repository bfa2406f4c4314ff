// Shared helpers of the shadow, ray-caster, scene-file and CLI tests: small procedural scenes built in
// code, a holder that owns a Scene with its macrocell grid and ShadowCasters, an independent
// (double-precision) box clip for closed forms, and the sanitizer scale switch.
#pragma once

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <unistd.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "penumbra/accel/macrocell_grid.h"
#include "penumbra/scene/scene.h"
#include "penumbra/scene_io/scene_file.h"
#include "penumbra/lighting/shadow_casters.h"

namespace penumbra::test {

// True under the sanitizer preset (PENUMBRA_TEST_SCALE=sanitize): tests may shrink sizes there.
inline bool sanitize_scale() {
  const char* s = std::getenv("PENUMBRA_TEST_SCALE");
  return s != nullptr && std::string(s) == "sanitize";
}

// A transfer function of constant opacity `a` (per voxel) and transmission colour (r, g, b) over the
// whole data range [0, 1].
inline nlohmann::json constant_tf(double a, double r = 0, double g = 0, double b = 0) {
  return {{"points", {{0.0, r, g, b, a}, {1.0, r, g, b, a}}}};
}

// A transfer function that is transparent below density 0.5 and has opacity `a` (colour r, g, b) from
// 0.5 up: a hard-edged medium wherever a binary density volume is 1.
inline nlohmann::json step_tf(double a, double r = 0, double g = 0, double b = 0) {
  return {{"points", {{0.0, r, g, b, 0.0}, {0.5, r, g, b, 0.0}, {0.5, r, g, b, a}, {1.0, r, g, b, a}}}};
}

// A scene with one procedural volume (size³ voxels on [-0.5, 0.5]³), no planes, one light.
inline nlohmann::json volume_scene(const nlohmann::json& procedural, const nlohmann::json& tf, double step = 0.5) {
  nlohmann::json j;
  j["volumes"] = nlohmann::json::array({{{"procedural", procedural}, {"transfer_function", tf}, {"step", step}}});
  j["lights"] = nlohmann::json::array({{{"type", "directional"}, {"direction", {0.0, -1.0, 0.0}}}});
  j["camera"] = {{"width", 32}, {"height", 32}};
  return j;
}

// The whole box filled with density 1: a slab thicker than the box.
inline nlohmann::json full_box_scene(int size, const nlohmann::json& tf, double step = 0.5) {
  return volume_scene({{"name", "slab"}, {"size", size}, {"thickness", 2.0}}, tf, step);
}

// A scene together with what a ShadowCasters needs; pinned in memory (the medium points into it).
struct MediumHolder {
  explicit MediumHolder(const nlohmann::json& j) : scene(build_scene(j, "")) {
    grid = std::make_unique<MacrocellGrid>(*scene.visible_volume()->volume);
    const std::vector<const MacrocellGrid*> grids{grid.get()};
    medium = std::make_unique<ShadowCasters>(scene, grids);
  }
  MediumHolder(const MediumHolder&) = delete;
  MediumHolder& operator=(const MediumHolder&) = delete;
  float voxel() const { return scene.visible_volume()->reference_step(); }  // Δref

  Scene scene;
  std::unique_ptr<MacrocellGrid> grid;
  std::unique_ptr<ShadowCasters> medium;
};

// Length of the part of the ray o + t·d, t in [t0, t1], inside the axis-aligned box [lo, hi]³
// (double precision, written independently of Box3::clip).
inline double length_in_box(const Vec3& o, const Vec3& d_in, double t0, double t1, double lo = -0.5, double hi = 0.5) {
  const double dl = std::sqrt(double(d_in.x) * d_in.x + double(d_in.y) * d_in.y + double(d_in.z) * d_in.z);
  const double d[3] = {d_in.x / dl, d_in.y / dl, d_in.z / dl};
  const double p[3] = {o.x, o.y, o.z};
  double a = t0, b = t1;
  for (int k = 0; k < 3; ++k) {
    if (d[k] == 0) {
      if (p[k] < lo || p[k] > hi) return 0;
      continue;
    }
    double ta = (lo - p[k]) / d[k], tb = (hi - p[k]) / d[k];
    if (ta > tb) std::swap(ta, tb);
    a = std::max(a, ta);
    b = std::min(b, tb);
  }
  return b > a ? b - a : 0;
}

// A directory named after the running test, removed with its contents when the test ends.
class ScratchDir {
public:
  ScratchDir() {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    std::string name = std::string("penumbra_") + info->test_suite_name() + "_" + info->name() + "_" + std::to_string(::getpid());
    for (char& c : name)
      if (c == '/') c = '_';
    path_ = std::filesystem::temp_directory_path() / name;
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~ScratchDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  const std::filesystem::path& path() const { return path_; }

private:
  std::filesystem::path path_;
};

}  // namespace penumbra::test
