#include "penumbra/engine/engine.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <functional>
#include <set>
#include <utility>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/data/transfer_function_choice.h"
#include "penumbra/engine/invalidation.h"
#include "penumbra/scene_io/json_reader.h"

namespace penumbra {
namespace {

// A preview aims at this much ray-casting time (render time grows with the pixels).
constexpr double kPreviewTargetMs = 40;

bool same_objects(const Scene& a, const Scene& b) {
  if (a.volumes.size() != b.volumes.size() || a.particles.size() != b.particles.size() ||
      a.isosurfaces.size() != b.isosurfaces.size() || a.planes.size() != b.planes.size())
    return false;
  for (std::size_t i = 0; i < a.volumes.size(); ++i)
    if (a.volumes[i].volume != b.volumes[i].volume || a.volumes[i].visible != b.volumes[i].visible) return false;
  return true;
}

// Puts `data` in place of the array `name` and rebuilds; the previous data comes back when that throws.
template <class Data>
void swap_array(std::map<std::string, std::shared_ptr<const Data>>* arrays, const std::string& name, std::shared_ptr<const Data> data,
                const char* what, const std::function<void()>& rebuild) {
  if (!arrays || !arrays->count(name)) throw Error(std::string("no ") + what + " array named \"" + name + "\" in this scene");
  auto previous = std::exchange((*arrays)[name], std::move(data));
  try {
    rebuild();
  } catch (...) {
    (*arrays)[name] = std::move(previous);
    throw;
  }
}

}  // namespace

Engine::Engine(nlohmann::json document, std::string base_dir, const SceneReadOptions& options)
    : document_(std::move(document)), base_dir_(std::move(base_dir)), strict_(options.strict) {
  if (options.arrays) arrays_ = *options.arrays;
  if (options.cache) cache_ = *options.cache;
  renderer_ = std::make_unique<Renderer>(build_scene(document_, base_dir_, read_options(&defaults_)));
  cache_.drop_unused();
}

Engine Engine::open(const std::string& scene_file, const std::vector<std::string>& overrides, const SceneReadOptions& options) {
  nlohmann::json j = read_json_file(scene_file);
  with_context(scene_file, [&] { for (const auto& o : overrides) apply_override(j, o); });
  return with_context(scene_file, [&] { return Engine(std::move(j), std::filesystem::path(scene_file).parent_path().string(), options); });
}

nlohmann::json Engine::saved_document(const std::string& folder) const {
  nlohmann::json saved = with_files_relative_to(document_, base_dir_, folder);
  const Scene& s = scene();
  if (saved.contains("volumes"))
    for (std::size_t i = 0; i < s.volumes.size() && i < saved["volumes"].size(); ++i) {
      auto& v = saved["volumes"][i];
      if (s.volumes[i].visible && !v.contains("transfer_function")) v["transfer_function"] = choose_transfer_function(*s.volumes[i].volume);
    }
  return saved;
}

const nlohmann::json* Engine::document_value(const std::string& path) const {
  const nlohmann::json* node = &document_;
  std::size_t start = 0;
  while (true) {
    const std::size_t dot = path.find('.', start);
    const std::string part = path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (node->is_array()) {
      const bool index = !part.empty() && std::all_of(part.begin(), part.end(), [](char c) { return c >= '0' && c <= '9'; });
      if (!index || part.size() > 9 || std::stoul(part) >= node->size()) return nullptr;
      node = &(*node)[std::stoul(part)];
    } else if (node->is_object() && node->contains(part) && !(*node)[part].is_null()) {
      node = &(*node)[part];
    } else {
      return nullptr;
    }
    if (dot == std::string::npos) return node;
    start = dot + 1;
  }
}

bool Engine::is_set(const std::string& path) const {
  if (document_value(path)) return true;
  (void)get(path);  // throws for an unknown path
  return false;
}

nlohmann::json Engine::get(const std::string& path) const {
  if (const nlohmann::json* value = document_value(path)) return *value;
  if (const auto it = defaults_.find(path); it != defaults_.end()) {
    // a volume's transfer function, chosen from its data, is written out as saved_document does
    const std::string prefix = "volumes.";
    const std::string suffix = ".transfer_function";
    if (it->second.is_null() && path.rfind(prefix, 0) == 0 && path.size() > suffix.size() &&
        path.compare(path.size() - suffix.size(), suffix.size(), suffix) == 0) {
      const std::string index = path.substr(prefix.size(), path.size() - prefix.size() - suffix.size());
      const auto& volumes = scene().volumes;
      if (!index.empty() && index.size() < 9 && std::all_of(index.begin(), index.end(), [](char c) { return c >= '0' && c <= '9'; }) &&
          std::stoul(index) < volumes.size())
        return choose_transfer_function(*volumes[std::stoul(index)].volume);
    }
    return it->second;
  }
  // An index past an array's end: say how many there are.
  for (std::size_t dot = path.find('.'); dot != std::string::npos; dot = path.find('.', dot + 1)) {
    const std::string head = path.substr(0, dot);
    const nlohmann::json* list = document_value(head);
    if (list && list->is_array()) {
      const std::size_t end = path.find('.', dot + 1);
      const std::string index = path.substr(dot + 1, end == std::string::npos ? std::string::npos : end - dot - 1);
      if (!document_value(head + "." + index))
        throw Error(path + ": no such element (" + head + " has " + std::to_string(list->size()) + ")");
    }
  }
  // Unknown: name the keys its object has (set or defaulted).
  const std::size_t dot = path.rfind('.');
  const std::string parent = dot == std::string::npos ? "" : path.substr(0, dot);
  std::set<std::string> keys;
  const auto add_key = [&](const std::string& full) {
    if (parent.empty() ? full.find('.') == std::string::npos : full.size() > parent.size() + 1 && full.compare(0, parent.size() + 1, parent + ".") == 0) {
      const std::string rest = parent.empty() ? full : full.substr(parent.size() + 1);
      keys.insert(rest.substr(0, rest.find('.')));
    }
  };
  for (const auto& [full, value] : defaults_) add_key(full);
  const nlohmann::json* object = parent.empty() ? &document_ : document_value(parent);
  if (object && object->is_object())
    for (const auto& [key, value] : object->items()) keys.insert(key);
  if (object && object->is_array())
    throw Error(path + ": no such element (" + parent + " has " + std::to_string(object->size()) + ")");
  std::string known;
  for (const auto& k : keys) known += (known.empty() ? "" : ", ") + k;
  if (keys.empty()) throw Error(path + ": not a key of the scene (docs/scene-file.md)");
  throw Error(path + ": not a key of the scene (" + (parent.empty() ? std::string("the scene") : parent) + " has: " + known + ")");
}

void Engine::edit(const std::vector<std::pair<std::string, nlohmann::json>>& edits) {
  nlohmann::json edited = document_;
  for (const auto& edit : edits) {
    const std::string& path = edit.first;
    check_utf8(path, "edit: the path");
    if (!invalidation_rule(path))
      throw Error(path + ": not a scene path (expected camera, lights.N, volumes.N, particles.N, isosurfaces.N, planes.N, "
                         "shadows, ambient, light_cache, shading, background, sphere_renderer, time or memory_budget, then a key of docs/scene-file.md)");
    with_context(path, [&] { set_path(edited, path, edit.second); });
  }
  std::vector<std::string> paths;
  for (const auto& e : edits) paths.push_back(e.first);
  apply(std::move(edited), paths);
}

void Engine::apply(nlohmann::json edited, const std::vector<std::string>& paths) {
  // read exactly like a scene file; the engine keeps its scene when this throws
  ReadDefaults defaults;
  Scene scene = with_context("edit refused", [&] { return build_scene(edited, base_dir_, read_options(&defaults)); });
  std::vector<std::string> stale;
  bool new_scene = !same_objects(scene, renderer_->scene());
  for (const auto& path : paths) {
    const std::vector<std::string> s = invalidated_by(path, scene);
    if (s.size() == 1 && s.front() == "scene") new_scene = true;
    for (const auto& name : s)
      if (!causes_.count(name)) causes_[name] = path;
    stale.insert(stale.end(), s.begin(), s.end());
  }
  if (new_scene) {
    renderer_ = std::make_unique<Renderer>(std::move(scene));
    new_renderer_ = true;
    causes_.clear();
    causes_["scene"] = paths.empty() ? "" : paths.front();
  } else {
    renderer_->apply_edit(scene, stale, lighting_only(paths));
  }
  document_ = std::move(edited);
  defaults_ = std::move(defaults);
  cache_.drop_unused();
  edits_.insert(edits_.end(), paths.begin(), paths.end());
  samples_ = 0;
}

void Engine::replace_array(const std::string& name, std::shared_ptr<const ParticleSet> particles) {
  if (!particles || particles->size() == 0) throw Error("particle array \"" + name + "\": holds no particles");
  swap_array(arrays_ ? &arrays_->particles : nullptr, name, std::move(particles), "particle", [&] { replace_array(name, "particles"); });
}

void Engine::replace_array(const std::string& name, std::shared_ptr<const Volume> volume) {
  if (!volume) throw Error("volume array \"" + name + "\": no volume");
  swap_array(arrays_ ? &arrays_->volumes : nullptr, name, std::move(volume), "volume", [&] { replace_array(name, "volumes"); });
}

void Engine::replace_array(const std::string& name, const char* kind) {
  std::vector<std::string> paths;  // the objects that name the array: as if their definition changed
  if (document_.contains(kind) && document_[kind].is_array())
    for (std::size_t i = 0; i < document_[kind].size(); ++i) {
      const auto& object = document_[kind][i];
      if (object.is_object() && object.contains("array") && object["array"] == name) paths.push_back(std::string(kind) + "." + std::to_string(i));
    }
  apply(document_, paths);
}

EngineFrame Engine::render(const FrameOptions& options) {
  FrameRequest request;
  request.quality = options.quality;
  request.cancel = options.cancel;
  request.enlarge_preview = options.enlarge_preview;
  if (options.quality == Quality::Preview)
    request.preview_divisor = std::clamp(static_cast<int>(std::ceil(std::sqrt(full_render_ms_ / kPreviewTargetMs))), 2, 8);
  const bool accumulating = options.quality == Quality::Full && options.accumulate && samples_ > 0 && last_quality_ == Quality::Full;
  request.sample = accumulating ? static_cast<std::uint32_t>(samples_) : 0;

  EngineFrame out;
  out.divisor = options.quality == Quality::Preview ? request.preview_divisor : 1;
  out.frame = renderer_->render(request);  // Cancelled propagates; nothing below has changed then
  const FrameResult& f = out.frame;
  for (const auto& name : f.rebuilt) {
    std::string cause;
    if (new_renderer_) cause = causes_.count("scene") && !causes_["scene"].empty() ? causes_["scene"] : "first frame";
    else if (causes_.count(name)) cause = causes_[name];
    else if (request.sample > 0) cause = "sample";
    else if (f.quality == Quality::Full && last_quality_ == Quality::Preview) cause = "refine";
    else cause = "needed";
    out.rebuilt.push_back({name, cause});
  }
  for (const auto& name : f.rebuilt) causes_.erase(name);
  if (f.quality == Quality::Full) {
    causes_.clear();
    new_renderer_ = false;
    full_render_ms_ = f.render_ms;
  }
  out.edits = std::move(edits_);
  edits_.clear();
  last_quality_ = f.quality;

  // accumulation
  if (f.quality == Quality::Full && options.accumulate) {
    // Colour and coverage are averaged alike: the mean image is then the mean premultiplied colour over
    // the background with the mean coverage, so the transparent output does not depend on the background.
    if (request.sample == 0) {
      sum_ = f.image.pixels();
      alpha_sum_ = f.alpha;
      samples_ = 1;
    } else {
      for (std::size_t i = 0; i < sum_.size(); ++i) sum_[i] += f.image.pixels()[i];
      for (std::size_t i = 0; i < alpha_sum_.size(); ++i) alpha_sum_[i] += f.alpha[i];
      ++samples_;
    }
    if (samples_ == 1) {
      out.image = std::move(out.frame.image);
    } else {
      out.image = Image(f.image.width(), f.image.height());
      const float inv = 1.0f / static_cast<float>(samples_);
      for (std::size_t i = 0; i < sum_.size(); ++i) out.image.pixels()[i] = sum_[i] * inv;
      for (std::size_t i = 0; i < alpha_sum_.size(); ++i) out.frame.alpha[i] = alpha_sum_[i] * inv;
    }
    out.samples = samples_;
  } else {
    samples_ = 0;
    out.image = std::move(out.frame.image);
  }
  if (options.buffers) write_frame_buffers(out.image, f, scene().background, *options.buffers);
  return out;
}

void write_frame_buffers(const Image& image, const FrameResult& frame, const Rgb& background, FrameBuffers& out) {
  const std::size_t n = image.pixels().size();
  auto check = [&](std::size_t size, std::size_t per_pixel, const char* name) {
    if (size != 0 && size != n * per_pixel)
      throw Error(std::string("frame buffers: ") + name + " holds " + std::to_string(size) + " values; expected " +
                  std::to_string(n * per_pixel) + " (" + std::to_string(image.width()) + " x " + std::to_string(image.height()) + " x " +
                  std::to_string(per_pixel) + ")");
  };
  check(out.rgba.size(), 4, "rgba");
  check(out.srgb8.size(), 4, "srgb8");
  check(out.depth.size(), 1, "depth");
  parallel_for(n, [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const float a = out.transparent_background ? frame.alpha[i] : 1.0f;
      // the image is colour + background·(1 − alpha); without the background it is premultiplied
      const Rgb c = out.transparent_background ? image.pixels()[i] - background * (1 - frame.alpha[i]) : image.pixels()[i];
      if (!out.rgba.empty()) {
        out.rgba[4 * i] = c.r;
        out.rgba[4 * i + 1] = c.g;
        out.rgba[4 * i + 2] = c.b;
        out.rgba[4 * i + 3] = a;
      }
      if (!out.srgb8.empty()) {
        const float inv = a > 0 ? 1 / a : 0;
        out.srgb8[4 * i] = linear_to_srgb8(c.r * inv);
        out.srgb8[4 * i + 1] = linear_to_srgb8(c.g * inv);
        out.srgb8[4 * i + 2] = linear_to_srgb8(c.b * inv);
        out.srgb8[4 * i + 3] = static_cast<std::uint8_t>(std::lround(std::clamp(a, 0.0f, 1.0f) * 255.0f));
      }
      if (!out.depth.empty()) out.depth[i] = frame.depth[i];
    }
  }, 1 << 14);
}

}  // namespace penumbra
