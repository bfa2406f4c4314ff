#include "stats.h"

#include <filesystem>
#include <fstream>

#include "penumbra/core/error.h"
#include "penumbra/particles/sphere_hits.h"

namespace penumbra::cli {

nlohmann::json frame_stats(const FrameResult& frame) {
  return {{"timings_ms",
           {{"sat", frame.sat_ms}, {"ambient", frame.ambient_ms}, {"build", frame.build_ms}, {"render", frame.render_ms},
            {"bvh", frame.bvh_ms}, {"hits", frame.hits_ms}, {"total", frame.total_ms}}},
          {"rebuilt", frame.rebuilt},
          {"issm_rings", frame.issm_rings},
          {"sphere_pixels", frame.sphere_pixels}};
}

nlohmann::json render_stats(const Scene& scene, const Renderer& renderer, const FrameResult& first, int threads) {
  nlohmann::json j;
  j["technique"] = scene.shadows.technique;
  j["ambient_technique"] = scene.ambient.technique;
  j["width"] = first.image.width();
  j["height"] = first.image.height();
  j["timings_ms"] = {{"prepare", renderer.prepare_ms()}, {"sat", first.sat_ms}, {"ambient", first.ambient_ms},
                     {"build", first.build_ms}, {"render", first.render_ms}, {"bvh", first.bvh_ms},
                     {"hits", first.hits_ms}, {"total", first.total_ms}};
  std::size_t volume_bytes = 0;
  for (const auto& v : scene.volumes) volume_bytes += v.volume->memory_bytes();
  j["memory_bytes"] = {{"shadow", renderer.shadow_memory_bytes()}, {"ambient", renderer.ambient_memory_bytes()},
                        {"sat", renderer.sat_memory_bytes()}, {"volume", volume_bytes},
                        {"particles", renderer.particle_memory_bytes()}, {"bvh", renderer.bvh_memory_bytes()}};
  j["counts"] = {{"voxels", renderer.voxel_count()}, {"spheres", renderer.sphere_count()}, {"points", 0},
                 {"lights", scene.lights.size()}, {"sphere_pixels", first.sphere_pixels}};
  if (scene.has_particles()) {
    j["sphere_renderer"] = to_string(scene.sphere_rasterizer);
    j["issm_rings"] = first.issm_rings;
  }
  j["threads"] = threads;
  j["seed"] = scene.shadows.seed;
  j["rebuilt"] = first.rebuilt;
  return j;
}

void write_json_file(const std::string& path, const nlohmann::json& j) {
  const std::filesystem::path target(path);
  const std::filesystem::path tmp = target.parent_path() / ("." + target.filename().string() + ".partial");
  {
    std::ofstream out(tmp);
    if (!out) throw Error(path + ": cannot open for writing");
    out << j.dump(2) << "\n";
    if (!out) throw Error(path + ": write failed");
  }
  std::filesystem::rename(tmp, target);
}

}  // namespace penumbra::cli
