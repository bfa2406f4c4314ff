// The options of `penumbra render`, shared by the single-process command (cmd_render.cpp) and the
// data-parallel one under mpirun (cmd_render_distributed.cpp).
#pragma once

#include <string>

#include "inputs.h"

namespace penumbra::cli {

struct RenderOptions {
  InputOptions in;
  std::string output, stats, buffers, edits, write_scene, frames, video, compositor;
  int width = 0, height = 0, threads = 0, orbit = 0, light_orbit = 0, accumulate = 1, fps = 10, slabs = 0;
  bool preview = false, depth = false;
};

std::string lower_extension(const std::string& path);
// Error unless -o names a .png, .pfm or .exr in an existing folder.
void check_output_path(const std::string& output);
// Error unless --stats names a file in an existing folder.
void check_stats_path(const std::string& stats);
bool sequence_requested(const RenderOptions& o);
// The image sizes the options set, as --set overrides ("camera.width=W").
std::vector<std::string> size_overrides(const RenderOptions& o);

// `render` under mpirun (distributed/distributed_frame.h).
void run_render_distributed(const RenderOptions& o);

}  // namespace penumbra::cli
