// Rendering one scene with several shadow techniques and measuring each against `ray_traced`: the
// common core of `penumbra demo` and `penumbra bench`.
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

#include "penumbra/core/image.h"

namespace penumbra::cli {

struct TechniqueRun {
  std::string technique;
  int resolution = 0;
  double build_ms = 0, render_ms = 0;
  std::size_t memory_bytes = 0;
  double rmse = 0, psnr = 0;  // against the ray_traced image (0 / inf for ray_traced itself)
  Image image;
};

// Where the shared data sets are looked for: $PENUMBRA_DATA_DIR, else ../shared/data beside the checkout.
std::string default_data_dir();

// Renders `scene` (JSON) with the given shadow settings overrides; takes the fastest of `repeats` runs.
TechniqueRun run_technique(const nlohmann::json& scene, const std::string& technique, int resolution,
                           const std::vector<std::string>& extra_sets, int repeats);

}  // namespace penumbra::cli
