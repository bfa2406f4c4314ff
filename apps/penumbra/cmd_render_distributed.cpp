// `mpirun -np N penumbra render SCENE -o OUT.png [--frames A:B[:STEP] | --orbit N | --light-orbit N]
//  [--video V.mp4] [--stats S.json] [--threads T] [--width W --height H] [--compositor C] [--set key=value ...]`: one
// frame, or a sequence (the frames of the scene's trajectories and volume series, or an orbit of the
// camera or the first light), rendered data-parallel (distributed/distributed_frame.h). Every rank
// opens the scene, anew for each time step (a rank reads its brick of the frame's step), and keeps its
// renderer while the data stay (an orbit rebuilds nothing, a light orbit that light's shadows); rank 0
// writes the images (OUT_000.png …) and the statistics, with one entry per rank (and per frame).
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <thread>

#include <nlohmann/json.hpp>

#include "mpi_launch.h"
#include "penumbra/core/error.h"
#include "penumbra/core/image_io.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/distributed/brick_reading.h"
#include "penumbra/distributed/distributed_frame.h"
#include "penumbra/distributed/sphere_split.h"
#include "render_options.h"
#include "render_sequence.h"
#include "stats.h"

namespace penumbra::cli {
namespace {

void check_distributed_options(const RenderOptions& o) {
  if (o.slabs > 0) throw Error("--slabs is the brick loop of one process; under mpirun the ranks are the slabs");
  if (!o.edits.empty() || o.accumulate > 1 || o.preview || o.depth || !o.buffers.empty() || !o.write_scene.empty())
    throw Error("under mpirun, render draws one frame or a sequence (--frames, --orbit, --light-orbit) to .png or .pfm "
                "(not with --edits, --accumulate, --preview, --depth, --buffers or --write-scene)");
  check_sequence_options(o);
  check_output_path(o.output);
  if (lower_extension(o.output) == ".exr") throw Error("-o " + o.output + ": under mpirun the output must be .png or .pfm");
  if (!o.stats.empty()) check_stats_path(o.stats);
}

// Ranks that share a node share its cores: each takes its share unless --threads says otherwise.
int threads_per_rank(const RenderOptions& o, const MpiWorld& world) {
  if (o.threads > 0) return o.threads;
  const int cores = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  return std::max(1, cores / world.local_size());
}

// Every rank must render the same scene: ranks given different ones (an MPMD launch) would call
// different collectives and wait on each other. Each rank hashes what it opened (the scene document
// with its overrides, or the data files and their options, and the output) and all compare with rank 0.
void check_same_scene(const RenderOptions& o, const std::optional<SceneDocument>& document, MpiWorld& world) {
  const std::string what = (document ? document->document.dump() + document->base_dir : nlohmann::json(o.in.inputs).dump()) +
                           "\n" + nlohmann::json(size_overrides(o)).dump() + "\n" + o.output;
  std::uint64_t hash = 1469598103934665603ull;  // FNV-1a
  for (const unsigned char c : what) hash = (hash ^ c) * 1099511628211ull;
  const int mine[] = {static_cast<int>(hash & 0x7fffffff), static_cast<int>((hash >> 31) & 0x7fffffff)};
  const std::vector<int> all = world.all_gather(mine);
  for (int r = 1; r < world.size(); ++r)
    if (all[static_cast<std::size_t>(r) * 2] != all[0] || all[static_cast<std::size_t>(r) * 2 + 1] != all[1])
      throw Error("rank " + std::to_string(r) + " of " + std::to_string(world.size()) +
                  " opened another scene than rank 0 (every rank must render the same scene, options and output)");
}

// What a rank read (distributed/brick_reading.h), gathered on rank 0.
struct RankReadStats {
  int first_slice = 0, slices = 0;
  std::uint64_t bytes_read = 0, volume_bytes = 0;
};

std::uint64_t file_bytes(const std::string& path) {
  std::error_code ec;
  const auto size = std::filesystem::is_regular_file(path, ec) ? std::filesystem::file_size(path, ec) : 0;
  return ec ? 0 : static_cast<std::uint64_t>(size);
}

nlohmann::json rank_stats(const RankFrameStats& s, const RankReadStats& read, int rank) {
  const auto z = [](float v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  nlohmann::json out = {{"rank", rank},
          {"slab_z", {z(s.slab.z_lo), z(s.slab.z_hi)}},
          {"slices", {read.first_slice, read.first_slice + read.slices}},
          {"bytes_read", read.bytes_read},
          {"volume_bytes", read.volume_bytes},
          {"prepare_ms", s.prepare_ms},
          {"build_ms", s.build_ms},
          {"render_ms", s.render_ms},
          {"composite_ms", s.composite_ms},
          {"compositing_ms", s.compositing_ms},
          {"communication_ms", s.communication_ms},
          {"bytes_sent", s.bytes_sent},
          {"shadow_bytes_sent", s.shadow_bytes_sent},
          {"image_bytes_sent", s.image_bytes_sent},
          {"structures_rebuilt", s.structures_rebuilt}};
  if (s.spheres) out["spheres"] = *s.spheres;
  return out;
}

// What every rank read and did for the first frame, printed by rank 0 (with the notes on what was not split).
template <typename ReadOf>
void print_first_frame(const Scene& scene, const BrickReading& reading, const DistributedFrame& frame, const ReadOf& read_of) {
  if (!reading.bricked && !scene.volumes.empty())
    std::fprintf(stderr, "penumbra: note: every rank read the whole volume: %s\n", reading.why.c_str());
  if (!scene.volumes.empty() && scene.has_particles())
    if (const std::string why = why_spheres_whole(scene); !why.empty())
      std::fprintf(stderr, "penumbra: note: every rank holds every sphere: %s\n", why.c_str());
  for (std::size_t r = 0; r < frame.ranks.size(); ++r) {
    const RankFrameStats& s = frame.ranks[r];
    const RankReadStats read = read_of(r);
    const std::string spheres = s.spheres ? std::to_string(*s.spheres) + " spheres" : "";
    if (scene.volumes.empty())
      std::fprintf(stderr, "rank %zu: %s\n", r, spheres.c_str());
    else
      std::fprintf(stderr, "rank %zu: slices %d to %d of %d (%.1f MB read, %.1f MB held)%s%s\n", r, read.first_slice,
                   read.first_slice + read.slices - 1, reading.whole_slices, static_cast<double>(read.bytes_read) / 1e6,
                   static_cast<double>(read.volume_bytes) / 1e6, spheres.empty() ? "" : ", ", spheres.c_str());
    std::fprintf(stderr, "rank %zu: %s z %g to %g, shadows %.1f ms, render %.1f ms, composite %.1f ms, communication %.1f ms, sent %.0f kB (shadows %.0f, image %.0f)\n",
                 r, scene.volumes.empty() ? "spheres" : "slab", static_cast<double>(s.slab.z_lo), static_cast<double>(s.slab.z_hi), s.build_ms, s.render_ms, s.composite_ms,
                 s.communication_ms, s.bytes_sent / 1024.0, s.shadow_bytes_sent / 1024.0, s.image_bytes_sent / 1024.0);
  }
}

}  // namespace

void run_render_distributed(const RenderOptions& o) {
  MpiWorld& world = *mpi_world();
  Timer total;
  ThreadLimit limit(threads_per_rank(o, world));
  std::optional<SceneDocument> document;
  DocumentCompletion complete;  // data files: their document completed from the data read (scene_io/data_scene.h)
  std::optional<Engine> engine;
  std::string error;
  Compositor compositor = Compositor::direct_send;
  try {
    check_distributed_options(o);
    if (!o.compositor.empty()) compositor = parse_compositor(o.compositor);
    const auto holds_volume = [](const nlohmann::json& d) {
      const auto volumes = d.find("volumes");
      return volumes != d.end() && !(volumes->is_array() && volumes->empty());
    };
    document = scene_file_document(o.in, size_overrides(o));
    // data files with a volume: read as bricks too, their transfer function chosen from the ranks' histogram
    if (!document)
      if (DataFilesDocument data = data_files_document(o.in, size_overrides(o)); holds_volume(data.document))
        document = SceneDocument{std::move(data.document), ""}, complete = std::move(data.complete);
    // A scene without a volume (nothing to read as bricks: molecules, a trajectory) opens as an engine
    // on every rank, whose trajectory readers stay open from one time step to the next.
    if (!document || !holds_volume(document->document)) engine.emplace(open_inputs(o.in, size_overrides(o)));
  } catch (const std::exception& e) {
    error = e.what();
  }
  error = world.agree(error);
  if (!error.empty()) throw Error(error);
  check_same_scene(o, document, world);

  // The scene at frame `time` of its trajectories and volume series (nullopt: the document's own): a
  // scene file's volume is read as bricks anew for every step, each rank reading only its brick of the
  // step; otherwise the engine moves to the step (data files opened directly are read whole by every rank).
  BrickReading reading;
  std::optional<Scene> scene;
  std::optional<DistributedRenderer> renderer;  // kept while the data stay: an orbit keeps its structures
  const auto open_frame = [&](std::optional<std::size_t> time) {
    renderer.reset();
    scene.reset();
    if (!engine) {
      if (time) document->document["time"] = *time;
      scene.emplace(build_distributed_scene(document->document, document->base_dir, o.in.strict, world, reading, complete));
      return;
    }
    if (time) world.run_agreed([&] { engine->set("time", *time); });
    scene.emplace(engine->scene());
    reading = BrickReading{};
    reading.why = why_read_whole(*scene);  // no volume: the particle files are read whole
    if (!document)
      for (const std::string& f : o.in.inputs) reading.bytes_read += file_bytes(f);
    if (!scene->volumes.empty()) {
      reading.whole_slices = scene->volumes.front().volume->dims()[2];
      reading.slices = {0, reading.whole_slices};
      reading.volume_bytes = scene->volumes.front().volume->memory_bytes();
    }
  };
  open_frame(std::nullopt);
  std::vector<std::size_t> times;
  world.run_agreed([&] {
    if (!o.frames.empty()) times = time_frames(o.frames, scene->frame_count());
  });
  const bool sequence = sequence_requested(o);
  const SequenceOrbits orbits(o, *scene);
  if (world.rank() == 0)
    for (const auto& note : scene->unread_keys) std::fprintf(stderr, "penumbra: note: %s\n", note.c_str());

  nlohmann::json stats;
  nlohmann::json frame_list = nlohmann::json::array();
  const int frames = std::max({1, o.orbit, o.light_orbit, static_cast<int>(times.size())});
  for (int f = 0; f < frames; ++f) {
    Timer frame_time;
    // an orbit turns the camera or the light of the scene held (nothing read again); a time step opens
    // the scene at that time
    orbits.apply(*scene, f, frames);
    const bool step = !times.empty() && (f > 0 || times[0] != scene->time);
    if (step) open_frame(times[static_cast<std::size_t>(f)]);
    const bool opened = f == 0 || step;  // this frame's bytes read: none when the scene was kept
    const double read_ms = frame_time.elapsed_ms();
    if (!renderer) renderer.emplace(*scene, world, compositor);
    const DistributedFrame frame = renderer->render(scene->camera, scene->lights);
    // every rank's reading to rank 0
    const double read_fields[] = {static_cast<double>(reading.slices.first), static_cast<double>(reading.slices.count),
                                  static_cast<double>(opened ? reading.bytes_read : 0), static_cast<double>(reading.volume_bytes)};
    const std::vector<double> reads = world.gather_doubles(read_fields);
    const auto read_of = [&](std::size_t r) {
      const double* v = &reads[r * std::size(read_fields)];
      return RankReadStats{static_cast<int>(v[0]), static_cast<int>(v[1]), static_cast<std::uint64_t>(v[2]), static_cast<std::uint64_t>(v[3])};
    };
    const std::string path = sequence ? frame_path(o.output, f) : o.output;
    if (world.rank() == 0) {
      try {
        write_image(path, frame.image);
      } catch (const std::exception& e) {
        error = e.what();
      }
      nlohmann::json ranks = nlohmann::json::array();
      for (std::size_t r = 0; r < frame.ranks.size(); ++r) ranks.push_back(rank_stats(frame.ranks[r], read_of(r), static_cast<int>(r)));
      if (f == 0) {
        stats = {{"ranks", ranks},
                 {"width", scene->camera.width},
                 {"height", scene->camera.height},
                 {"threads_per_rank", ThreadLimit::current_max()},
                 {"compositing", compositor_name(compositor) + (scene->volumes.empty() ? ", by depth" : ", in visibility order")},
                 {"split", scene->volumes.empty() ? "spheres by z order" : "volume slabs"},
                 {"spheres_whole_because", scene->volumes.empty() || !scene->has_particles() ? "" : why_spheres_whole(*scene)},
                 {"bricks_read", reading.bricked},
                 {"whole_slices", reading.whole_slices},
                 {"cut_from_whole_file", reading.cut_from_whole}};
        if (!reading.bricked) stats["read_whole_because"] = reading.why;
        print_first_frame(*scene, reading, frame, read_of);
      }
      if (sequence) {
        nlohmann::json fs = {{"file", path}, {"open_ms", read_ms}, {"ms", frame_time.elapsed_ms()}, {"rebuilt", frame.rebuilt}, {"ranks", ranks}};
        if (!times.empty()) fs["time"] = scene->time;
        frame_list.push_back(fs);
        const std::string time = times.empty() ? "" : "time " + std::to_string(scene->time) + ", ";
        std::fprintf(stderr, "%s: %s%d ranks, scene opened in %.1f ms, %.1f ms in all\n", path.c_str(), time.c_str(), world.size(), read_ms,
                     frame_time.elapsed_ms());
      }
    }
    error = world.agree(error);  // a failed write stops every rank with its message
    if (!error.empty()) throw Error(error);
  }

  if (world.rank() == 0) {
    try {
      if (!o.stats.empty()) {
        if (sequence) stats["frames"] = frame_list;
        write_json_file(o.stats, stats);
      }
      if (!o.video.empty()) write_video(o.output, o.video, frames, o.fps);
    } catch (const std::exception& e) {
      error = e.what();
    }
    if (error.empty())
      std::fprintf(stderr, "%s: %d ranks, %d frame%s, composited by %s, %.1f ms in all\n", o.output.c_str(), world.size(), frames,
                   frames == 1 ? "" : "s", compositor_name(compositor).c_str(), total.elapsed_ms());
  }
  error = world.agree(error);
  if (!error.empty()) throw Error(error);
}

}  // namespace penumbra::cli
