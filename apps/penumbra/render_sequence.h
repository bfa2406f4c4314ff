// The image sequences of `penumbra render` (--frames, --orbit, --light-orbit, --video), shared by the
// single-process command and the one under mpirun: the frames' file names, the --frames range, and
// the video made from the frames by Debian's ffmpeg.
#pragma once

#include <cstddef>
#include <string>
#include <utility>
#include <vector>

#include <nlohmann/json.hpp>

#include "penumbra/scene/scene.h"
#include "render_options.h"

namespace penumbra::cli {

// NAME_007.EXT for frame 7 of a sequence written to NAME.EXT.
std::string frame_path(const std::string& output, int frame);

// --frames A:B[:STEP] over a scene of `count` frames: A, A + STEP, … up to B (inclusive; B left out:
// the last frame). An Error naming the range when it does not fit the scene.
std::vector<std::size_t> time_frames(const std::string& spec, std::size_t count);

// Error unless the sequence options fit together: one of --orbit, --light-orbit and --frames, and
// --video only with a sequence of .png frames and ffmpeg installed.
void check_sequence_options(const RenderOptions& o);

// --orbit N and --light-orbit N: frame f turns the camera's eye (or the first light) by 2π f / N about
// the camera's up axis, through its target (the light: through the scene's centre, so that a light
// orbit of a z-up CT turns around the patient's long axis too).
class SequenceOrbits {
public:
  SequenceOrbits(const RenderOptions& o, const Scene& first_frame);
  // The scene edits that make frame f of `frames` (none for frame 0, or without an orbit).
  std::vector<std::pair<std::string, nlohmann::json>> edits(int f, int frames) const;
  // The same frame made in place: `scene` becomes what the scene file reads after edits(f, frames)
  // (the camera's eye, the first light's direction, normalised as the file's reading does, and position),
  // without reading the scene's data again.
  void apply(Scene& scene, int f, int frames) const;

private:
  float angle(int f, int frames) const;
  Light light(int f, int frames) const;

  bool camera_, light_;
  Camera camera0_;
  std::vector<Light> lights0_;
  Vec3 centre_;
};

// The frames NAME_000.png … NAME_{count-1}.png as a video through ffmpeg (H.264, yuv420p: what every
// player plays).
void write_video(const std::string& output, const std::string& video, int count, int fps);

}  // namespace penumbra::cli
