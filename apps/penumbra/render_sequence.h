// The image sequences of `penumbra render` (--frames, --orbit, --light-orbit, --video), shared by the
// single-process command and the one under mpirun: the frames' file names, the --frames range, and
// the video made from the frames by Debian's ffmpeg.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "render_options.h"

namespace penumbra::cli {

// NAME_007.EXT for frame 7 of a sequence written to NAME.EXT.
std::string frame_path(const std::string& output, int frame);

// --frames A:B[:STEP] over a scene of `count` frames: A, A + STEP, … up to B (inclusive; B left out:
// the last frame). An Error naming the range when it does not fit the scene.
std::vector<std::size_t> time_frames(const std::string& spec, std::size_t count);

// Error unless --video (when given) can be made: a sequence is rendered, its frames are .png, and
// ffmpeg is installed.
void check_video_options(const RenderOptions& o);

// The frames NAME_000.png … NAME_{count-1}.png as a video through ffmpeg (H.264, yuv420p: what every
// player plays).
void write_video(const std::string& output, const std::string& video, int count, int fps);

}  // namespace penumbra::cli
