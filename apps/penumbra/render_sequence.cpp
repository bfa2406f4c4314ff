#include "render_sequence.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>

#include "penumbra/core/error.h"

namespace penumbra::cli {

std::string frame_path(const std::string& output, int frame) {
  const std::filesystem::path p(output);
  char suffix[16];
  std::snprintf(suffix, sizeof suffix, "_%03d", frame);
  return (p.parent_path() / (p.stem().string() + suffix + p.extension().string())).string();
}

std::vector<std::size_t> time_frames(const std::string& spec, std::size_t count) {
  auto fail = [&](const std::string& why) -> std::vector<std::size_t> {
    throw Error("--frames " + spec + ": " + why);
  };
  if (count == 0) return fail("the scene has no trajectory or volume series (nothing has frames)");
  std::vector<std::string> parts{""};
  for (char c : spec) {
    if (c == ':') parts.emplace_back();
    else parts.back() += c;
  }
  if (parts.size() < 2 || parts.size() > 3) return fail("expected A:B or A:B:STEP (frame indices, B inclusive)");
  auto number = [&](const std::string& text, std::size_t fallback) -> std::size_t {
    if (text.empty()) return fallback;
    if (!std::all_of(text.begin(), text.end(), [](char c) { return c >= '0' && c <= '9'; }) || text.size() > 9)
      throw Error("--frames " + spec + ": '" + text + "' is not a frame index (a whole number)");
    return static_cast<std::size_t>(std::stoul(text));
  };
  const std::size_t first = number(parts[0], 0), last = number(parts[1], count - 1);
  const std::size_t step = parts.size() == 3 ? number(parts[2], 1) : 1;
  if (step == 0) return fail("STEP must be at least 1");
  if (last >= count) return fail("frame " + std::to_string(last) + " is past the last frame (" + std::to_string(count) + " frames, 0 to " +
                                 std::to_string(count - 1) + ")");
  if (first > last) return fail("A is after B");
  std::vector<std::size_t> frames;
  for (std::size_t k = first; k <= last; k += step) frames.push_back(k);
  return frames;
}

void check_sequence_options(const RenderOptions& o) {
  if (int(o.orbit > 0) + int(o.light_orbit > 0) + int(!o.frames.empty()) > 1)
    throw Error("--orbit, --light-orbit and --frames cannot be combined");
  if (o.video.empty()) return;
  if (!sequence_requested(o)) throw Error("--video needs a sequence: --frames, --orbit or --light-orbit");
  if (std::system("ffmpeg -version > /dev/null 2>&1") != 0)
    throw Error("--video " + o.video + ": ffmpeg not found (install Debian's ffmpeg); the frames can still be written without --video");
  if (std::filesystem::path(o.output).extension() != ".png") throw Error("--video: the frames (-o) must be .png");
}

namespace {

nlohmann::json vec3_json(const Vec3& v) { return nlohmann::json::array({v.x, v.y, v.z}); }

Light orbit_light(const Light& l, const Vec3& centre, const Vec3& up, float angle) {
  const Vec3 axis = normalize(up);
  const float c = std::cos(angle), s = std::sin(angle);
  auto rot = [&](const Vec3& v) { return v * c + cross(axis, v) * s + axis * (dot(axis, v) * (1 - c)); };
  Light out = l;
  out.direction = normalize(rot(l.direction));
  if (l.type != LightType::Directional) out.position = centre + rot(l.position - centre);
  return out;
}

}  // namespace

SequenceOrbits::SequenceOrbits(const RenderOptions& o, const Scene& first_frame)
    : camera_(o.orbit > 0), light_(o.light_orbit > 0 && !first_frame.lights.empty()), camera0_(first_frame.camera),
      lights0_(first_frame.lights), centre_(first_frame.caster_bounds().center()) {}

float SequenceOrbits::angle(int f, int frames) const { return 2.0f * kPi * static_cast<float>(f) / static_cast<float>(frames); }

Light SequenceOrbits::light(int f, int frames) const { return orbit_light(lights0_[0], centre_, camera0_.up, angle(f, frames)); }

std::vector<std::pair<std::string, nlohmann::json>> SequenceOrbits::edits(int f, int frames) const {
  std::vector<std::pair<std::string, nlohmann::json>> out;
  if (f == 0) return out;
  if (camera_) out.emplace_back("camera.eye", vec3_json(camera0_.orbited(angle(f, frames)).eye));
  if (light_) {
    const Light l = light(f, frames);
    if (l.type != LightType::Point) out.emplace_back("lights.0.direction", vec3_json(l.direction));  // a point light has no direction
    if (l.type != LightType::Directional) out.emplace_back("lights.0.position", vec3_json(l.position));
  }
  return out;
}

void SequenceOrbits::apply(Scene& scene, int f, int frames) const {
  if (f == 0) return;
  if (camera_) scene.camera.eye = camera0_.orbited(angle(f, frames)).eye;
  if (light_) {
    const Light l = light(f, frames);
    if (l.type != LightType::Point) scene.lights[0].direction = normalize(l.direction);
    if (l.type != LightType::Directional) scene.lights[0].position = l.position;
  }
}

void write_video(const std::string& output, const std::string& video, int count, int fps) {
  const std::filesystem::path p(output);
  const std::string pattern = (p.parent_path() / (p.stem().string() + "_%03d" + p.extension().string())).string();
  for (const std::string* s : {&pattern, &video})
    if (s->find('\'') != std::string::npos) throw Error("--video: file names with a quote are not supported");
  const std::string command = "ffmpeg -y -loglevel error -framerate " + std::to_string(fps) + " -i '" + pattern +
                              "' -frames:v " + std::to_string(count) +
                              " -vf 'pad=ceil(iw/2)*2:ceil(ih/2)*2' -c:v libx264 -pix_fmt yuv420p '" + video + "'";
  if (std::system(command.c_str()) != 0) throw Error("--video " + video + ": ffmpeg failed (command: " + command + ")");
  std::fprintf(stderr, "%s: %d frames at %d fps\n", video.c_str(), count, fps);
}

}  // namespace penumbra::cli
