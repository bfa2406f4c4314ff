// `penumbra render (SCENE.json | DATA_FILE...) -o OUT.png|.pfm|.exr [--depth] [--width W --height H] [--set key=value ...]
//  [--stats S.json] [--threads N] [--orbit N | --light-orbit N | --frames A:B[:STEP] [--video V.mp4] | --edits FILE]
//  [--strict] [--slabs N] [--compositor direct-send|icet|icet-bswap]
//  [--write-scene S.json] [--raw-dims X Y Z --raw-type T ...]`
// Data files (volumes, molecules) make a scene of their own (scene_io/data_scene.h). Every frame goes
// through the interactive engine (engine/engine.h): an orbit edits camera.eye or the first light each
// frame, --frames steps the scene's `time` through trajectories and volume series (each frame reading
// only its data and rebuilding what moved), and --edits replays a recorded interaction.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <thread>
#include <vector>

#include "commands.h"
#include "inputs.h"
#include "mpi_launch.h"
#include "render_options.h"
#include "render_sequence.h"
#include "penumbra/core/cancel.h"
#include "penumbra/core/error.h"
#include "penumbra/core/exr_io.h"
#include "penumbra/core/image_io.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/distributed/volume_slabs.h"
#include "penumbra/isosurface/light_pass.h"
#include "penumbra/render/isosurface_buffers.h"
#include "penumbra/engine/engine.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene_io/scene_file.h"
#include "penumbra/registry/technique_catalog.h"
#include "stats.h"

namespace penumbra::cli {

std::string lower_extension(const std::string& path) {
  std::string ext = std::filesystem::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return ext;
}

void check_output_path(const std::string& output) {
  const std::string ext = lower_extension(output);
  if (ext != ".png" && ext != ".pfm" && ext != ".exr")
    throw Error("-o " + output + ": unknown image extension '" + std::filesystem::path(output).extension().string() +
                "' (expected .png, .pfm or .exr)");
  const auto dir = std::filesystem::path(output).parent_path();
  if (!dir.empty() && !std::filesystem::is_directory(dir))
    throw Error("-o " + output + ": directory '" + dir.string() + "' does not exist");
}

void check_stats_path(const std::string& stats) {
  const auto dir = std::filesystem::path(stats).parent_path();
  if (!dir.empty() && !std::filesystem::is_directory(dir))
    throw Error("--stats " + stats + ": directory '" + dir.string() + "' does not exist");
}

bool sequence_requested(const RenderOptions& o) { return o.orbit > 0 || o.light_orbit > 0 || !o.frames.empty(); }

std::vector<std::string> size_overrides(const RenderOptions& o) {
  std::vector<std::string> sizes;
  if (o.width > 0) sizes.push_back("camera.width=" + std::to_string(o.width));
  if (o.height > 0) sizes.push_back("camera.height=" + std::to_string(o.height));
  return sizes;
}

namespace {

// A refined box that could not be read (a corrupt chunk) is the command's error: the opened level drawn
// in its place would pass for the finer data (the viewer and Python draw it, the error in their stats).
void require_refined(const FrameResult& frame) {
  for (const auto& r : frame.refinement)
    if (!r.error.empty()) throw Error("volumes." + std::to_string(r.volume) + ": " + r.error);
}

// PNG and PFM hold the picture over the scene's background. EXR holds linear colour with premultiplied
// alpha (nothing behind the data: alpha 0, to composite over anything) and, with --depth, the distance
// along each primary ray (Z; +infinity where nothing is hit).
void write_output(const std::string& path, const EngineFrame& ef, const Scene& scene, bool depth) {
  if (lower_extension(path) != ".exr") {
    write_image(path, ef.image);
    return;
  }
  ExrImage exr;
  exr.width = ef.image.width();
  exr.height = ef.image.height();
  const std::size_t n = ef.image.pixels().size();
  exr.rgba.resize(4 * n);
  if (depth) exr.depth.resize(n);
  FrameBuffers buffers{exr.rgba, {}, exr.depth, true};
  write_frame_buffers(ef.image, ef.frame, scene.background, buffers);
  write_exr(path, exr);
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

// "issm (spheres) + cssm (volumes)": which technique covers which kind of caster.
std::string technique_line(const Scene& scene) {
  std::string techniques;
  for (const ShadowAssignment& a : shadow_assignments(scene)) {
    std::string kinds;
    for (int k = 0; k < kObjectKinds; ++k)
      if (a.casters & kind_bit(static_cast<ObjectKind>(k))) kinds += (kinds.empty() ? "" : ", ") + to_string(static_cast<ObjectKind>(k));
    techniques += (techniques.empty() ? "" : " + ") + a.technique + " (" + kinds + ")";
  }
  return techniques.empty() ? "none" : techniques;
}

nlohmann::json rebuilt_json(const std::vector<RebuiltStructure>& rebuilt) {
  nlohmann::json a = nlohmann::json::array();
  for (const auto& r : rebuilt) a.push_back({{"structure", r.structure}, {"cause", r.cause}});
  return a;
}

// One step of an --edits file: the edits and how long to let the image refine afterwards.
struct EditStep {
  std::vector<std::pair<std::string, nlohmann::json>> set;
  double idle_ms = 0;
  double cancel_after_ms = -1;  // >= 0: first start a full frame and cancel it after this long
};

// Starts a full frame, cancels it after `after_ms` from another thread, and returns how long the frame
// took to return once the flag was set (negative when it finished first).
double cancel_latency_ms(Engine& engine, double after_ms) {
  std::atomic<bool> cancel{false};
  std::chrono::steady_clock::time_point set_at;
  std::atomic<bool> was_set{false};
  std::thread canceller([&] {
    std::this_thread::sleep_for(std::chrono::duration<double, std::milli>(after_ms));
    set_at = std::chrono::steady_clock::now();
    was_set = true;
    cancel = true;
  });
  bool cancelled = false;
  try {
    engine.render({Quality::Full, false, &cancel});
  } catch (const Cancelled&) {
    cancelled = true;
  }
  const auto end = std::chrono::steady_clock::now();
  canceller.join();
  return cancelled ? std::chrono::duration<double, std::milli>(end - set_at).count() : -1.0;
}

std::vector<EditStep> read_edit_steps(const std::string& path) {
  const nlohmann::json j = read_json_file(path);
  if (!j.is_array()) throw Error(path + ": expected a JSON list of steps, each {\"set\": {\"PATH\": VALUE, ...}, \"idle_ms\": N}");
  std::vector<EditStep> steps;
  for (std::size_t i = 0; i < j.size(); ++i) {
    const std::string where = path + ": step " + std::to_string(i);
    const nlohmann::json& s = j[i];
    if (!s.is_object()) throw Error(where + ": expected an object {\"set\": {...}, \"idle_ms\": N}");
    EditStep step;
    for (const auto& [key, value] : s.items()) {
      if (key == "set") {
        if (!value.is_object() || value.empty()) throw Error(where + ": 'set' must be an object of one or more {\"PATH\": VALUE}");
        for (const auto& [p, v] : value.items()) step.set.emplace_back(p, v);
      } else if (key == "cancel_after_ms") {
        if (!value.is_number() || value.get<double>() < 0 || value.get<double>() > 600000)
          throw Error(where + ": 'cancel_after_ms' must be a number of milliseconds in [0, 600000]");
        step.cancel_after_ms = value.get<double>();
      } else if (key == "idle_ms") {
        if (!value.is_number() || value.get<double>() < 0 || value.get<double>() > 600000)
          throw Error(where + ": 'idle_ms' must be a number of milliseconds in [0, 600000]");
        step.idle_ms = value.get<double>();
      } else {
        throw Error(where + ": unknown key '" + key + "' (expected set, idle_ms, cancel_after_ms)");
      }
    }
    if (step.set.empty()) throw Error(where + ": no 'set'");
    steps.push_back(std::move(step));
  }
  return steps;
}

// Replays an interaction: each step's edits, then a preview and the full-quality frame (what a viewer
// shows while the hand moves and once it stops), then accumulated samples while `idle_ms` lasts.
nlohmann::json replay_edits(Engine& engine, const std::vector<EditStep>& steps, const std::string& file, EngineFrame& last) {
  nlohmann::json out = nlohmann::json::array();
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const EditStep& step = steps[i];
    const auto start = std::chrono::steady_clock::now();
    auto since = [&] { return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count(); };
    with_context(file + ": step " + std::to_string(i), [&] { engine.edit(step.set); });
    nlohmann::json cancel;
    if (step.cancel_after_ms >= 0) {
      const double latency = cancel_latency_ms(engine, step.cancel_after_ms);
      cancel = latency >= 0 ? nlohmann::json{{"after_ms", step.cancel_after_ms}, {"returned_ms", latency}}
                            : nlohmann::json{{"after_ms", step.cancel_after_ms}, {"finished_first", true}};
    }
    const EngineFrame preview = engine.render({Quality::Preview});
    const double preview_ms = since();
    EngineFrame full = engine.render({Quality::Full});
    require_refined(full.frame);
    const double full_ms = since();
    const auto refined = full.rebuilt;  // what the first full frame rebuilt, before idle samples
    const nlohmann::json refinement = refinement_json(full.frame.refinement);
    while (since() < full_ms + step.idle_ms) full = engine.render({Quality::Full});
    const int samples = full.samples;
    nlohmann::json paths = nlohmann::json::array();
    for (const auto& [p, v] : step.set) paths.push_back(p);
    out.push_back({{"paths", paths},
                   {"rebuilt", rebuilt_json(preview.rebuilt)},
                   {"refined", rebuilt_json(refined)},
                   {"preview_ms", preview_ms},
                   {"full_ms", full_ms},
                   {"preview_divisor", preview.divisor},
                   {"samples", samples},
                   {"refinement", refinement}});
    if (!cancel.is_null()) out.back()["cancel"] = cancel;
    std::fprintf(stderr, "step %zu: %s: preview %.1f ms, full %.1f ms%s\n", i, paths.dump().c_str(), preview_ms, full_ms,
                 samples > 1 ? (", " + std::to_string(samples) + " samples").c_str() : "");
    last = std::move(full);
  }
  return out;
}


// --slabs N: sort-last rendering as a brick loop in one process (distributed/volume_slabs.h).
void render_slabs(const RenderOptions& o, const Engine& engine) {
  Timer total;
  const SlabFrame f = with_context("--slabs", [&] { return render_in_slabs(engine.scene(), o.slabs); });
  for (std::size_t b = 0; b < f.slabs.size(); ++b)
    std::fprintf(stderr, "slab %zu of %zu: z from %g to %g, render %.1f ms\n", b + 1, f.slabs.size(), static_cast<double>(f.slabs[b].z_lo),
                 static_cast<double>(f.slabs[b].z_hi), f.render_ms[b]);
  std::fprintf(stderr, "%s: %zu slabs composited in %.1f ms (%.1f ms in all)\n", o.output.c_str(), f.slabs.size(), f.composite_ms,
               total.elapsed_ms());
  write_image(o.output, f.image);
}

void run_render(const RenderOptions& o) {
  if (!o.compositor.empty()) throw Error("--compositor " + o.compositor + ": it composites the ranks of mpirun -np N (one process composites nothing)");
  if (o.slabs > 0 && (sequence_requested(o) || !o.edits.empty() || o.accumulate > 1 || o.preview || o.depth || !o.buffers.empty() ||
                      !o.stats.empty() || !o.write_scene.empty()))
    throw Error("--slabs renders one frame to a .png or .pfm (not with --orbit, --light-orbit, --frames, --edits, --accumulate, "
                "--preview, --depth, --buffers, --stats or --write-scene)");
  if (o.slabs > 0 && lower_extension(o.output) == ".exr") throw Error("--slabs: the output must be .png or .pfm");
  check_sequence_options(o);
  if (!o.edits.empty() && sequence_requested(o)) throw Error("--edits cannot be combined with --orbit, --light-orbit or --frames");
  if (o.preview && (o.accumulate > 1 || !o.edits.empty())) throw Error("--preview renders one preview frame (not with --accumulate or --edits)");
  if (o.accumulate > 1 && (sequence_requested(o) || !o.edits.empty()))
    throw Error("--accumulate applies to a single frame (not with --orbit, --light-orbit, --frames or --edits)");
  check_output_path(o.output);
  if (o.depth && lower_extension(o.output) != ".exr") throw Error("--depth: the depth is written into an .exr output (-o NAME.exr)");
  if (!o.buffers.empty() && !std::filesystem::is_directory(o.buffers))
    throw Error("--buffers " + o.buffers + ": not a directory");
  if (!o.stats.empty()) check_stats_path(o.stats);
  const std::vector<EditStep> steps = o.edits.empty() ? std::vector<EditStep>{} : read_edit_steps(o.edits);
  if (!o.write_scene.empty()) check_scene_file_path(o.write_scene);
  ThreadLimit limit(o.threads);
  Engine engine = open_inputs(o.in, size_overrides(o));
  const Scene& scene = engine.scene();
  for (const auto& note : scene.unread_keys) std::fprintf(stderr, "penumbra: note: %s\n", note.c_str());
  if (o.slabs > 0) return render_slabs(o, engine);
  if (!o.buffers.empty() && !scene.has_isosurfaces()) throw Error("--buffers: the scene has no isosurface");
  const std::vector<std::size_t> times = o.frames.empty() ? std::vector<std::size_t>{} : time_frames(o.frames, scene.frame_count());
  const int frames = std::max({1, o.orbit, o.light_orbit, static_cast<int>(times.size())});
  const bool sequence = sequence_requested(o);
  const SequenceOrbits orbits(o, scene);
  nlohmann::json stats;
  nlohmann::json frame_list = nlohmann::json::array();
  for (int f = 0; f < frames; ++f) {
    double read_ms = 0;
    if (!times.empty() && (f > 0 || times[0] != engine.scene().time)) {
      Timer read;  // reading the frame's data (and the scene around it)
      engine.set("time", times[static_cast<std::size_t>(f)]);
      read_ms = read.elapsed_ms();
    }
    if (const auto edits = orbits.edits(f, frames); !edits.empty()) engine.edit(edits);
    EngineFrame ef = engine.render({o.preview ? Quality::Preview : Quality::Full, o.accumulate > 1});
    const FrameResult frame = ef.frame;  // the first sample's stats
    require_refined(frame);
    for (int k = 1; k < o.accumulate; ++k) ef = engine.render({Quality::Full, true});
    const std::string path = sequence ? frame_path(o.output, f) : o.output;
    if (steps.empty()) write_output(path, ef, engine.scene(), o.depth);
    if (f == 0) stats = render_stats(engine.scene(), engine.renderer(), frame, ThreadLimit::current_max());
    if (f == 0 && !o.buffers.empty()) write_isosurface_buffers(o.buffers, engine.renderer(), engine.scene().camera);
    nlohmann::json fs = frame_stats(frame);
    fs["file"] = path;
    if (!times.empty()) {
      fs["time"] = engine.scene().time;
      fs["read_ms"] = read_ms;
      for (const auto& p : engine.scene().particles)
        if (p.frames > 0) fs["time_ps"] = p.time_ps;
    }
    frame_list.push_back(fs);
    std::string rebuilt;
    for (const auto& r : frame.rebuilt) rebuilt += (rebuilt.empty() ? " (rebuilt " : ", ") + r;
    std::fprintf(stderr, "%s: %s, sat %.1f ms, ambient %.1f ms, shadows %.1f ms, render %.1f ms%s\n", path.c_str(),
                 technique_line(engine.scene()).c_str(), frame.sat_ms, frame.ambient_ms, frame.build_ms, frame.render_ms,
                 rebuilt.empty() || f == 0 ? "" : (rebuilt + ")").c_str());
  }
  if (!steps.empty()) {
    EngineFrame last;
    stats["edits"] = replay_edits(engine, steps, o.edits, last);
    write_output(o.output, last, engine.scene(), o.depth);
  }
  if (!o.stats.empty()) {
    if (sequence) stats["frames"] = frame_list;
    write_json_file(o.stats, stats);
  }
  if (!o.write_scene.empty()) write_scene_file(engine, o.write_scene);
  if (!o.video.empty()) write_video(o.output, o.video, frames, o.fps);
}

}  // namespace

void add_render_command(CLI::App& app) {
  auto o = std::make_shared<RenderOptions>();
  CLI::App* cmd = app.add_subcommand("render", "Render a scene file, or data files, to an image (.png: 8-bit sRGB, .pfm: float RGB, "
                                             ".exr: float RGBA and, with --depth, Z)");
  add_input_options(*cmd, o->in);
  cmd->add_option("--write-scene", o->write_scene, "Also save the scene as a scene file (.json; paths relative to its folder): "
                                                   "what data files opened directly became, to edit and render again");
  cmd->add_option("-o,--output", o->output, "Output image (.png, .pfm or .exr); with --orbit/--light-orbit/--frames, frames go to NAME_000.png ...")->required();
  cmd->add_option("--width", o->width, "Image width (overrides camera.width)")->check(CLI::Range(1, 16384));
  cmd->add_option("--height", o->height, "Image height (overrides camera.height)")->check(CLI::Range(1, 16384));
  cmd->add_option("--stats", o->stats, "Write timings, memory and counts as JSON");
  cmd->add_option("--buffers", o->buffers,
                  "Isosurface scenes: write the eye pass's final visibility mask and each light pass's holes and "
                  "points (light view) as PNGs into this directory (lightN_isoK_* with several isosurfaces)");
  cmd->add_option("--threads", o->threads, "Worker threads (0 = all cores)")->check(CLI::Range(0, 1024));
  cmd->add_option("--orbit", o->orbit, "Render N frames with the camera turning once around its target")->check(CLI::Range(1, 100000));
  cmd->add_option("--light-orbit", o->light_orbit, "Render N frames with the first light turning once around the scene")->check(CLI::Range(1, 100000));
  cmd->add_option("--accumulate", o->accumulate,
                  "Average N samples (new jitter and cssm seeds each): the image the viewer converges to while idle")
      ->check(CLI::Range(1, 100000));
  cmd->add_option("--frames", o->frames,
                  "Render the frames A to B (inclusive; B left out: the last), every STEP, of the scene's trajectories and "
                  "volume series: A:B[:STEP]; images go to NAME_000.png ...");
  cmd->add_option("--video", o->video, "With a sequence: also encode its frames as a video (.mp4) through ffmpeg");
  cmd->add_option("--fps", o->fps, "Frames per second of --video (default 10)")->check(CLI::Range(1, 240));
  cmd->add_flag("--depth", o->depth, "With -o NAME.exr: also write the depth (channel Z: distance along each primary ray; +inf where nothing is hit)");
  cmd->add_option("--slabs", o->slabs,
                  "Sort-last brick loop: split the volume into N slabs along z, ray cast each alone and composite them "
                  "along every pixel's ray (what a data-parallel frame does; scenes with a volume)")
      ->check(CLI::Range(1, 65536));
  cmd->add_option("--compositor", o->compositor,
                  "Under mpirun: how the ranks' images are composited: direct-send (default), icet (IceT, radix-k) or "
                  "icet-bswap (IceT, binary swap)");
  cmd->add_flag("--preview", o->preview, "Render what the viewer shows while the hand moves: the engine's preview quality");
  cmd->add_option("--edits", o->edits,
                  "Replay an interaction: a JSON list of steps {\"set\": {\"PATH\": VALUE, ...}, \"idle_ms\": N}; each step's "
                  "preview and full-quality times (and what it rebuilt) go to --stats under 'edits'; -o gets the last image");
  cmd->callback([o] {
    if (mpi_world() != nullptr)
      defer_to_all_ranks([o] { run_render_distributed(*o); });
    else
      run_render(*o);
  });
}

}  // namespace penumbra::cli
