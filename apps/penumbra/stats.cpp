#include "stats.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <set>

#include "penumbra/core/error.h"
#include "penumbra/core/replace_file.h"
#include "penumbra/particles/sphere_hits.h"
#include "penumbra/registry/technique_catalog.h"

namespace penumbra::cli {

nlohmann::json frame_stats(const FrameResult& frame) {
  const IsosurfaceFrameStats& iso = frame.isosurface;
  return {{"timings_ms",
           {{"sat", frame.sat_ms}, {"ambient", frame.ambient_ms}, {"build", frame.build_ms}, {"render", frame.render_ms},
            {"bvh", frame.bvh_ms}, {"hits", frame.hits_ms}, {"extract", iso.extract_ms}, {"mesh", iso.mesh_ms},
            {"shadow_pass", iso.shadow_ms}, {"shade", iso.shade_ms}, {"total", frame.total_ms}}},
          {"rebuilt", frame.rebuilt},
          {"issm_rings", frame.issm_rings},
          {"ambient_kept", frame.ambient_kept},
          {"surfaces_kept", frame.surfaces_kept},
          {"sphere_pixels", frame.sphere_pixels},
          {"points", iso.points},
          {"light_points", iso.light_points},
          {"refinement", refinement_json(frame.refinement)}};
}

nlohmann::json render_stats(const Scene& scene, const Renderer& renderer, const FrameResult& first, int threads) {
  nlohmann::json j;
  j["technique"] = scene.shadows.technique;
  nlohmann::json by_kind = nlohmann::json::object();  // which technique covered which kind of caster
  for (const ShadowAssignment& a : shadow_assignments(scene))
    for (int k = 0; k < kObjectKinds; ++k)
      if (a.casters & kind_bit(static_cast<ObjectKind>(k))) by_kind[to_string(static_cast<ObjectKind>(k))] = a.technique;
  j["shadow_techniques"] = by_kind;
  j["ambient_technique"] = scene.ambient.technique;
  j["width"] = first.image.width();
  j["height"] = first.image.height();
  j["timings_ms"] = {{"prepare", renderer.prepare_ms()}, {"sat", first.sat_ms}, {"ambient", first.ambient_ms},
                     {"build", first.build_ms}, {"render", first.render_ms}, {"bvh", first.bvh_ms},
                     {"hits", first.hits_ms}, {"extract", first.isosurface.extract_ms},
                     {"mesh", first.isosurface.mesh_ms}, {"shadow_pass", first.isosurface.shadow_ms},
                     {"shade", first.isosurface.shade_ms}, {"total", first.total_ms}};
  std::size_t volume_bytes = 0;
  for (const auto& v : scene.volumes) volume_bytes += v.volume->memory_bytes();
  j["memory_bytes"] = {{"shadow", renderer.shadow_memory_bytes()}, {"ambient", renderer.ambient_memory_bytes()},
                        {"sat", renderer.sat_memory_bytes()}, {"volume", volume_bytes},
                        {"volume_structures", renderer.volume_structure_memory_bytes()},
                        {"particles", renderer.particle_memory_bytes()}, {"bvh", renderer.bvh_memory_bytes()},
                        {"light_cache", renderer.light_cache_memory_bytes()}};
  // Each volume as it was read (a pyramid's level is seen in its dims), and against the scene's
  // memory_budget what the volumes hold: voxels and their structures (gradients, macrocells).
  j["volumes"] = nlohmann::json::array();
  for (const auto& v : scene.volumes) {
    const auto& d = v.volume->dims();
    j["volumes"].push_back({{"source", v.source}, {"dims", {d[0], d[1], d[2]}}, {"type", to_string(v.volume->type())},
                            {"bytes", v.volume->memory_bytes()}});
  }
  if (scene.memory_budget > 0)
    j["memory_budget"] = {{"budget", scene.memory_budget},
                          {"held", volume_bytes + renderer.volume_structure_memory_bytes() + renderer.refined_memory_bytes()}};
  j["memory_bytes"]["refined"] = renderer.refined_memory_bytes();
  j["refinement"] = refinement_json(first.refinement);
  const IsosurfaceFrameStats& iso = first.isosurface;
  j["counts"] = {{"voxels", renderer.voxel_count()}, {"spheres", renderer.sphere_count()}, {"points", iso.points},
                 {"lights", scene.lights.size()}, {"sphere_pixels", first.sphere_pixels},
                 {"volume_samples", first.volume_samples}, {"volume_shaded_samples", first.volume_shaded_samples}};
  // What the eye pass got through per second of its time (render_ms: the surfaces and the ray casting
  // together), to hold against the machine's ceiling (docs/BENCHMARKS.md).
  const double render_s = std::max(first.render_ms, 1e-3) / 1000.0;
  j["throughput"] = {{"samples_per_second", static_cast<double>(first.volume_samples) / render_s},
                     {"sphere_pixels_per_second", static_cast<double>(first.sphere_pixels) / render_s}};
  if (!renderer.isosurfaces().empty()) {
    nlohmann::json surfaces = nlohmann::json::array();
    std::set<const GridTree*> trees;
    double tree_ms = 0;
    std::size_t tree_bytes = 0, mesh_bytes = 0;
    for (const auto& p : renderer.isosurfaces()) {
      surfaces.push_back({{"method", to_string(p->object->method)}, {"value", p->object->value}, {"volume", p->object->volume}});
      if (trees.insert(p->tree.get()).second) {
        tree_ms += p->tree->build_ms();
        tree_bytes += p->tree->memory_bytes();
      }
      if (p->mesh) mesh_bytes += p->mesh->memory_bytes();
    }
    j["isosurface"] = {{"surfaces", surfaces}, {"grid_tree_ms", tree_ms}, {"grid_tree_bytes", tree_bytes},
                       {"light_points", iso.light_points}, {"holes", iso.holes}, {"triangles", iso.triangles},
                       {"nodes_visited", iso.extraction.nodes_visited}, {"value_pruned", iso.extraction.value_pruned},
                       {"visibility_pruned", iso.extraction.visibility_pruned},
                       {"cells_visited", iso.extraction.cells_visited}, {"collapsed", iso.extraction.collapsed}};
    j["memory_bytes"]["grid_tree"] = tree_bytes;
    if (mesh_bytes) j["memory_bytes"]["mesh"] = mesh_bytes;
  }
  if (scene.has_particles()) {
    // per particle set: the spheres drawn (none for a hidden set), and the atoms its `select` kept (null
    // without one)
    j["particles"] = nlohmann::json::array();
    for (const ParticleObject& p : scene.particles)
      j["particles"].push_back({{"source", p.source}, {"spheres", p.visible ? p.set->size() : 0}, {"visible", p.visible},
                                {"selected", p.selected_atoms ? nlohmann::json(*p.selected_atoms) : nlohmann::json(nullptr)}});
    j["sphere_renderer"] = to_string(scene.sphere_rasterizer);
    j["issm_rings"] = first.issm_rings;
  }
  j["threads"] = threads;
  if (const ParamSpec* seed = find_param(TechniqueFamily::Shadow, "seed")) j["seed"] = seed->integer(scene.shadows.params);
  j["rebuilt"] = first.rebuilt;
  return j;
}

void write_json_file(const std::string& path, const nlohmann::json& j) {
  with_context(path, [&] { replace_file_contents(path, j.dump(2) + "\n"); });
}

}  // namespace penumbra::cli
