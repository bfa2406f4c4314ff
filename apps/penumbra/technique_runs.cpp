#include "technique_runs.h"

#include <cstdlib>
#include <limits>

#include "penumbra/render/renderer.h"
#include "penumbra/scene_io/scene_file.h"

namespace penumbra::cli {

std::string default_data_dir() {
  const char* env = std::getenv("PENUMBRA_DATA_DIR");
  return env && *env ? std::string(env) : std::string(PENUMBRA_SHARED_DATA_DIR);
}

TechniqueRun run_technique(const nlohmann::json& scene_json, const std::string& technique, int resolution,
                           const std::vector<std::string>& extra_sets, int repeats) {
  nlohmann::json j = scene_json;
  apply_override(j, "shadows.technique", technique);
  apply_override(j, "shadows.resolution", std::to_string(resolution));
  for (const auto& s : extra_sets) apply_override(j, s);
  const Scene scene = build_scene(j, "");
  TechniqueRun run;
  run.technique = technique;
  run.resolution = resolution;
  run.build_ms = run.render_ms = std::numeric_limits<double>::infinity();
  for (int r = 0; r < std::max(1, repeats); ++r) {
    Renderer renderer(scene);  // fresh, so every repeat builds its shadow structure again
    FrameResult f = renderer.render();
    run.build_ms = std::min(run.build_ms, f.build_ms);
    run.render_ms = std::min(run.render_ms, f.render_ms);
    run.memory_bytes = renderer.shadow_memory_bytes();
    run.image = std::move(f.image);
  }
  return run;
}

}  // namespace penumbra::cli
