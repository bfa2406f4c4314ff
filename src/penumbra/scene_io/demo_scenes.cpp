#include "penumbra/scene_io/demo_scenes.h"

namespace penumbra {

nlohmann::json test_spheres_scene(int size) {
  return nlohmann::json::parse(R"({
    "volumes": [ { "procedural": { "name": "test-spheres", "size": 128 },
                   "transfer_function": { "preset": "test-spheres" }, "step": 0.5 } ],
    "planes": [ { "point": [0, -0.52, 0], "normal": [0, 1, 0], "color": [0.9, 0.9, 0.9], "size": 4 } ],
    "lights": [ { "type": "point", "position": [0.7, 1.6, 0.9], "intensity": 1.0 } ],
    "camera": { "direction": [1.0, 0.7, 1.6], "fov_deg": 35, "width": 512, "height": 512 },
    "shadows": { "technique": "cssm", "resolution": 1024, "offsets": 13, "seed": 1 },
    "background": [0.08, 0.08, 0.1]
  })")
      .patch(nlohmann::json::parse(R"([{"op": "replace", "path": "/volumes/0/procedural/size", "value": )" +
                                   std::to_string(size) + "}]"));
}

nlohmann::json cranium_scene(const std::string& path) {
  nlohmann::json j = nlohmann::json::parse(R"({
    "volumes": [ { "file": "", "transfer_function": { "preset": "ct-soft-tissue" }, "step": 0.5 } ],
    "planes": [ { "point": [122, 122, -8], "normal": [0, 0, 1], "color": [0.9, 0.9, 0.9], "size": 1200 } ],
    "lights": [ { "type": "directional", "direction": [0.6, -0.45, -1.0], "intensity": 1.0 } ],
    "camera": { "direction": [0.35, 1.0, 0.45], "up": [0, 0, 1], "fov_deg": 35, "width": 512, "height": 512 },
    "shadows": { "technique": "cssm", "resolution": 1024, "offsets": 13, "seed": 1 },
    "background": [0.08, 0.08, 0.1]
  })");
  j["volumes"][0]["file"] = path;
  return j;
}

nlohmann::json chest_scene(const std::string& path) {
  nlohmann::json j = nlohmann::json::parse(R"({
    "volumes": [ { "file": "", "step": 0.5,
                   "transfer_function": { "points": [[0, 0, 0, 0, 0], [60, 0.6, 0.25, 0.2, 0], [90, 0.85, 0.5, 0.4, 0.04],
                                                     [140, 0.95, 0.9, 0.8, 0.3], [255, 1, 1, 1, 0.6]] } } ],
    "lights": [ { "type": "spot", "position": [180, 600, 400], "angle_deg": 35 } ],
    "camera": { "direction": [0.3, 1.0, 0.4], "up": [0, 0, 1], "fov_deg": 35, "width": 512, "height": 512 },
    "shadows": { "technique": "deep_shadow_map", "resolution": 1024, "nodes": 4 },
    "background": [0.08, 0.08, 0.1]
  })");
  j["volumes"][0]["file"] = path;
  return j;
}

nlohmann::json spheres_floor_scene() {
  return nlohmann::json::parse(R"({
    "particles": [ { "procedural": { "name": "random-spheres", "count": 3000, "radius": 0.025, "seed": 3 } } ],
    "planes": [ { "point": [0, -0.6, 0], "normal": [0, 1, 0], "color": [0.85, 0.85, 0.85], "size": 4 } ],
    "lights": [ { "type": "directional", "direction": [-0.4, -1.0, -0.3] } ],
    "camera": { "eye": [1.6, 1.1, 2.0], "target": [0, -0.15, 0], "fov_deg": 40, "width": 512, "height": 512 },
    "shadows": { "technique": "issm", "resolution": 1024, "rings": 1 },
    "ambient": { "technique": "particle_ao" },
    "shading": { "ambient": 0.3, "diffuse": 0.75, "specular": 0.3, "shininess": 40 },
    "background": [0.08, 0.08, 0.1]
  })");
}

nlohmann::json molecule_scene(const std::string& path) {
  nlohmann::json j = nlohmann::json::parse(R"({
    "particles": [ { "file": "", "color_by": "chain" } ],
    "lights": [ { "type": "directional", "direction": [-0.45, -0.8, -0.4] } ],
    "camera": { "direction": [0.2, 0.3, 1.0], "fov_deg": 30, "zoom": 1.45, "width": 512, "height": 512 },
    "shadows": { "technique": "issm", "resolution": 512, "rings": 1 },
    "ambient": { "technique": "particle_ao", "directions": 16, "max_distance": 0.7 },
    "shading": { "ambient": 0.35, "diffuse": 0.75, "specular": 0.3, "shininess": 40 },
    "background": [1, 1, 1]
  })");
  j["particles"][0]["file"] = path;
  return j;
}

nlohmann::json ct_body_scene(int nx, int ny, int nz) {
  nlohmann::json j = nlohmann::json::parse(R"({
    "volumes": [ { "procedural": { "name": "ct-body" }, "visible": false } ],
    "isosurfaces": [ { "value": 1400, "method": "points" } ],
    "lights": [ { "type": "point", "position": [1200, 1400, 1500] } ],
    "camera": { "direction": [0.35, 1.0, 0.25], "up": [0, 0, 1], "target": [0, 0, 300], "zoom": 1.9,
                "width": 512, "height": 512 },
    "shadows": { "technique": "light_pass", "resolution": 512 }
  })");
  j["volumes"][0]["procedural"]["dims"] = {nx, ny, nz};
  return j;
}

}  // namespace penumbra
