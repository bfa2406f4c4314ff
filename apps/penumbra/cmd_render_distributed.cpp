// `mpirun -np N penumbra render SCENE -o OUT.png [--stats S.json] [--threads T] [--width W --height H]
//  [--set key=value ...]`: one frame rendered data-parallel (distributed/distributed_frame.h). Every
// rank opens the scene; rank 0 writes the image and the statistics, with one entry per rank.
#include <algorithm>
#include <cstdio>
#include <optional>
#include <thread>

#include <nlohmann/json.hpp>

#include "mpi_launch.h"
#include "penumbra/core/error.h"
#include "penumbra/core/image_io.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/distributed/distributed_frame.h"
#include "render_options.h"
#include "stats.h"

namespace penumbra::cli {
namespace {

void check_distributed_options(const RenderOptions& o) {
  if (o.slabs > 0) throw Error("--slabs is the brick loop of one process; under mpirun the ranks are the slabs");
  if (sequence_requested(o) || !o.edits.empty() || o.accumulate > 1 || o.preview || o.depth || !o.buffers.empty() ||
      !o.write_scene.empty())
    throw Error("under mpirun, render draws one frame to a .png or .pfm (not with --orbit, --light-orbit, --frames, --edits, "
                "--accumulate, --preview, --depth, --buffers or --write-scene)");
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

nlohmann::json rank_stats(const RankFrameStats& s, int rank) {
  const auto z = [](float v) { return std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr); };
  return {{"rank", rank},
          {"slab_z", {z(s.slab.z_lo), z(s.slab.z_hi)}},
          {"prepare_ms", s.prepare_ms},
          {"build_ms", s.build_ms},
          {"render_ms", s.render_ms},
          {"composite_ms", s.composite_ms},
          {"communication_ms", s.communication_ms},
          {"bytes_sent", s.bytes_sent},
          {"shadow_bytes_sent", s.shadow_bytes_sent},
          {"image_bytes_sent", s.image_bytes_sent}};
}

}  // namespace

void run_render_distributed(const RenderOptions& o) {
  MpiWorld& world = *mpi_world();
  Timer total;
  ThreadLimit limit(threads_per_rank(o, world));
  std::optional<Engine> engine;
  std::string error;
  try {
    check_distributed_options(o);
    engine.emplace(open_inputs(o.in, size_overrides(o)));
  } catch (const std::exception& e) {
    error = e.what();
  }
  error = world.agree(error);
  if (!error.empty()) throw Error(error);
  const Scene& scene = engine->scene();
  if (world.rank() == 0)
    for (const auto& note : scene.unread_keys) std::fprintf(stderr, "penumbra: note: %s\n", note.c_str());

  const DistributedFrame frame = render_distributed(scene, world);

  if (world.rank() == 0) {
    try {
      write_image(o.output, frame.image);
      if (!o.stats.empty()) {
        nlohmann::json stats = {{"ranks", nlohmann::json::array()},
                                {"width", scene.camera.width},
                                {"height", scene.camera.height},
                                {"threads_per_rank", ThreadLimit::current_max()},
                                {"compositing", "direct-send"}};
        for (std::size_t r = 0; r < frame.ranks.size(); ++r) stats["ranks"].push_back(rank_stats(frame.ranks[r], static_cast<int>(r)));
        write_json_file(o.stats, stats);
      }
    } catch (const std::exception& e) {
      error = e.what();
    }
    for (std::size_t r = 0; r < frame.ranks.size(); ++r) {
      const RankFrameStats& s = frame.ranks[r];
      std::fprintf(stderr, "rank %zu: slab z %g to %g, shadows %.1f ms, render %.1f ms, composite %.1f ms, communication %.1f ms, sent %.0f kB (shadows %.0f, image %.0f)\n",
                   r, static_cast<double>(s.slab.z_lo), static_cast<double>(s.slab.z_hi), s.build_ms, s.render_ms, s.composite_ms,
                   s.communication_ms, s.bytes_sent / 1024.0, s.shadow_bytes_sent / 1024.0, s.image_bytes_sent / 1024.0);
    }
    if (error.empty())
      std::fprintf(stderr, "%s: %d ranks, %.1f ms in all\n", o.output.c_str(), world.size(), total.elapsed_ms());
  }
  error = world.agree(error);  // a failed write stops every rank with its message
  if (!error.empty()) throw Error(error);
}

}  // namespace penumbra::cli
