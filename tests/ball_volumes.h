// The two balls of the refinement tests (test_view_refinement.cpp reads them as an OME-Zarr pyramid,
// test_reduced_refinement.cpp as an NRRD read reduced), and the close view of them both tests draw.
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <string>

#include "penumbra/data/volume.h"

namespace penumbra::test {

// A ball of density 1 and a smaller one of `small_density` beside it (block means keep both values:
// every reduction has the finest grid's value range), `size`³ float voxels over [-0.5, 0.5)³.
inline Volume ball_volume(int size, float small_density = 0.5f) {
  const float h = 1.0f / static_cast<float>(size);
  Volume v(ScalarType::Float32, {size, size, size}, {h, h, h}, {-0.5f, -0.5f, -0.5f});
  std::size_t n = 0;
  for (int k = 0; k < size; ++k)
    for (int j = 0; j < size; ++j)
      for (int i = 0; i < size; ++i) {
        const Vec3 p = v.origin() + v.spacing() * Vec3{static_cast<float>(i), static_cast<float>(j), static_cast<float>(k)};
        const float big = length(p - Vec3{0.05f, 0.0f, 0.0f}), small = length(p - Vec3{-0.3f, 0.2f, 0.1f});
        v.set_value(n++, big < 0.3f ? 1.0f : small < 0.12f ? small_density : 0.0f);
      }
  v.recompute_range();
  return v;
}

// A close view of the balls from `file` (translucent, a directional light, `shadows`' technique, 96²),
// under `budget` (0: none), refined in full frames or not.
inline nlohmann::json ball_view_scene(const std::string& file, std::uint64_t budget, bool refine, const std::string& shadows) {
  nlohmann::json j;
  nlohmann::json v = {{"file", file}, {"step", 0.5}, {"refine", refine}, {"jitter", false},
                      {"transfer_function", {{"points", {{0.0, 0.2, 0.4, 0.9, 0.0}, {0.4, 0.2, 0.4, 0.9, 0.0}, {0.5, 0.9, 0.5, 0.2, 0.3}, {1.0, 1.0, 0.9, 0.8, 0.6}}}}}};
  j["volumes"] = nlohmann::json::array({v});
  j["lights"] = nlohmann::json::array({{{"type", "directional"}, {"direction", {-0.3, -1.0, -0.5}}}});
  j["shadows"] = {{"technique", shadows}};
  j["camera"] = {{"eye", {-0.12, 0.15, 0.8}}, {"target", {-0.22, 0.12, 0.1}}, {"fov_deg", 15}, {"width", 96}, {"height", 96}};
  if (budget) j["memory_budget"] = budget;
  return j;
}

}  // namespace penumbra::test
