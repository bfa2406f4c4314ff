// `penumbra render SCENE.json -o OUT.png [--width W --height H] [--set key=value ...] [--stats S.json]
//  [--threads N] [--orbit N | --light-orbit N] [--strict]`
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "commands.h"
#include "penumbra/core/error.h"
#include "penumbra/core/image_io.h"
#include "penumbra/core/parallel.h"
#include "penumbra/isosurface/light_pass.h"
#include "penumbra/render/isosurface_buffers.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene/scene_file.h"
#include "penumbra/scene/technique_catalog.h"
#include "stats.h"

namespace penumbra::cli {
namespace {

struct RenderOptions {
  std::string scene, output, stats, buffers;
  int width = 0, height = 0, threads = 0, orbit = 0, light_orbit = 0;
  bool strict = false;
  std::vector<std::string> sets;
};

std::string frame_path(const std::string& output, int frame) {
  const std::filesystem::path p(output);
  char suffix[16];
  std::snprintf(suffix, sizeof suffix, "_%03d", frame);
  return (p.parent_path() / (p.stem().string() + suffix + p.extension().string())).string();
}

// paper 002 Fig. 2 (the eye pass's final visibility mask) and Fig. 6 (the view from the light).
void write_isosurface_buffers(const std::string& dir, const Renderer& renderer, const Camera& camera) {
  write_image(dir + "/eye_visibility.png", coverage_image(renderer.isosurface_eye_points(), camera.width, camera.height));
  const auto& lights = renderer.light_shadows();
  for (std::size_t l = 0; l < lights.size(); ++l)
    for (const auto& technique : lights[l]->techniques()) {
      const auto* pass = dynamic_cast<const LightPass*>(technique.get());  // the buffers only the light pass has
      if (!pass) continue;
      const auto& passes = pass->passes();
      for (std::size_t k = 0; k < passes.size(); ++k) {
        std::string stem = dir + "/light" + std::to_string(l);
        if (passes.size() > 1) stem += "_iso" + std::to_string(k);
        write_image(stem + "_holes.png", visibility_image(passes[k].holes));
        write_image(stem + "_points.png", distance_image(passes[k].light_points.points, passes[k].view.width, passes[k].view.height));
      }
    }
}

void check_output_path(const std::string& output) {
  std::string ext = std::filesystem::path(output).extension().string();
  if (ext != ".png" && ext != ".pfm")
    throw Error("-o " + output + ": unknown image extension '" + ext + "' (expected .png or .pfm)");
  const auto dir = std::filesystem::path(output).parent_path();
  if (!dir.empty() && !std::filesystem::is_directory(dir))
    throw Error("-o " + output + ": directory '" + dir.string() + "' does not exist");
}

// The first light turned by `angle` about the camera's up axis through the scene's centre (the axis the
// camera orbits about, so a light orbit of a z-up CT turns around the patient's long axis too).
Light orbit_light(const Light& l, const Vec3& centre, const Vec3& up, float angle) {
  const Vec3 axis = normalize(up);
  const float c = std::cos(angle), s = std::sin(angle);
  auto rot = [&](const Vec3& v) { return v * c + cross(axis, v) * s + axis * (dot(axis, v) * (1 - c)); };
  Light out = l;
  out.direction = normalize(rot(l.direction));
  if (l.type != LightType::Directional) out.position = centre + rot(l.position - centre);
  return out;
}

void run_render(const RenderOptions& o) {
  if (o.orbit > 0 && o.light_orbit > 0) throw Error("--orbit and --light-orbit cannot be combined");
  check_output_path(o.output);
  if (!o.buffers.empty() && !std::filesystem::is_directory(o.buffers))
    throw Error("--buffers " + o.buffers + ": not a directory");
  if (!o.stats.empty()) {
    const auto dir = std::filesystem::path(o.stats).parent_path();
    if (!dir.empty() && !std::filesystem::is_directory(dir))
      throw Error("--stats " + o.stats + ": directory '" + dir.string() + "' does not exist");
  }
  std::vector<std::string> sets;
  if (o.width > 0) sets.push_back("camera.width=" + std::to_string(o.width));
  if (o.height > 0) sets.push_back("camera.height=" + std::to_string(o.height));
  sets.insert(sets.end(), o.sets.begin(), o.sets.end());
  ThreadLimit limit(o.threads);
  const Scene scene = load_scene(o.scene, sets, SceneReadOptions{o.strict});
  for (const auto& note : scene.unread_keys) std::fprintf(stderr, "penumbra: note: %s\n", note.c_str());
  if (!o.buffers.empty() && !scene.has_isosurfaces()) throw Error("--buffers: " + o.scene + " has no isosurface");
  Renderer renderer(scene);
  const int frames = std::max({1, o.orbit, o.light_orbit});
  const bool sequence = o.orbit > 0 || o.light_orbit > 0;
  nlohmann::json stats;
  nlohmann::json frame_list = nlohmann::json::array();
  for (int f = 0; f < frames; ++f) {
    Camera camera = scene.camera;
    std::vector<Light> lights = scene.lights;
    const float angle = 2.0f * kPi * static_cast<float>(f) / static_cast<float>(frames);
    if (o.orbit > 0) camera = camera.orbited(angle);
    if (o.light_orbit > 0 && !lights.empty()) lights[0] = orbit_light(lights[0], scene.caster_bounds().center(), scene.camera.up, angle);
    const FrameResult frame = renderer.render(camera, lights);
    // which technique covers which kind of caster, e.g. "issm (spheres) + cssm (volumes)"
    std::string techniques;
    for (const ShadowAssignment& a : shadow_assignments(scene)) {
      std::string kinds;
      for (int k = 0; k < kObjectKinds; ++k)
        if (a.casters & kind_bit(static_cast<ObjectKind>(k))) kinds += (kinds.empty() ? "" : ", ") + to_string(static_cast<ObjectKind>(k));
      techniques += (techniques.empty() ? "" : " + ") + a.technique + " (" + kinds + ")";
    }
    if (techniques.empty()) techniques = "none";
    const std::string path = sequence ? frame_path(o.output, f) : o.output;
    write_image(path, frame.image);
    if (f == 0) stats = render_stats(scene, renderer, frame, ThreadLimit::current_max());
    if (f == 0 && !o.buffers.empty()) write_isosurface_buffers(o.buffers, renderer, camera);
    nlohmann::json fs = frame_stats(frame);
    fs["file"] = path;
    frame_list.push_back(fs);
    std::string rebuilt;
    for (const auto& r : frame.rebuilt) rebuilt += (rebuilt.empty() ? " (rebuilt " : ", ") + r;
    std::fprintf(stderr, "%s: %s, sat %.1f ms, ambient %.1f ms, shadows %.1f ms, render %.1f ms%s\n", path.c_str(),
                 techniques.c_str(), frame.sat_ms, frame.ambient_ms, frame.build_ms, frame.render_ms,
                 rebuilt.empty() ? "" : (rebuilt + ")").c_str());
  }
  if (!o.stats.empty()) {
    if (sequence) stats["frames"] = frame_list;
    write_json_file(o.stats, stats);
  }
}

}  // namespace

void add_render_command(CLI::App& app) {
  auto o = std::make_shared<RenderOptions>();
  CLI::App* cmd = app.add_subcommand("render", "Render a scene file to an image (.png: 8-bit sRGB, .pfm: float)");
  cmd->add_option("scene", o->scene, "Scene file (JSON, docs/scene-file.md)")->required();
  cmd->add_option("-o,--output", o->output, "Output image (.png or .pfm); with --orbit/--light-orbit, frames go to NAME_000.png ...")->required();
  cmd->add_option("--width", o->width, "Image width (overrides camera.width)")->check(CLI::Range(1, 16384));
  cmd->add_option("--height", o->height, "Image height (overrides camera.height)")->check(CLI::Range(1, 16384));
  cmd->add_option("--set", o->sets, "Override a scene value by dotted path: key=value (value parsed as JSON if valid)");
  cmd->add_option("--stats", o->stats, "Write timings, memory and counts as JSON");
  cmd->add_option("--buffers", o->buffers,
                  "Isosurface scenes: write the eye pass's final visibility mask and each light pass's holes and "
                  "points (light view) as PNGs into this directory (lightN_isoK_* with several isosurfaces)");
  cmd->add_flag("--strict", o->strict, "Keys that the chosen techniques do not read are an error (exit 1, no image), not a note");
  cmd->add_option("--threads", o->threads, "Worker threads (0 = all cores)")->check(CLI::Range(0, 1024));
  cmd->add_option("--orbit", o->orbit, "Render N frames with the camera turning once around its target")->check(CLI::Range(1, 100000));
  cmd->add_option("--light-orbit", o->light_orbit, "Render N frames with the first light turning once around the scene")->check(CLI::Range(1, 100000));
  cmd->callback([o] { run_render(*o); });
}

}  // namespace penumbra::cli
