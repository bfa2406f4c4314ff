// The interactive engine: a scene that changes while frames keep coming. What the viewer and the
// Python module drive.
//
//   Engine engine = Engine::open("scenes/cranium.json");
//   engine.edit({{"lights.0.direction", {0, -1, 0.3}}});    // validated like the scene file
//   EngineFrame preview = engine.render({Quality::Preview}); // follows the user's hand
//   EngineFrame full = engine.render();                      // full quality; later calls accumulate
//
// Edits name scene paths exactly as `--set` does, with JSON values. The edited document is read again
// by the scene reader (so an edit is checked exactly like a scene file; data whose definition did not
// change is not loaded again), and an edit that the reader refuses leaves the engine as it was. The
// invalidation table (invalidation.h) says which of the renderer's structures each path makes stale;
// the next frame rebuilds those and reports each with the edit that caused it.
//
// While nothing changes, full-quality frames accumulate: sample k moves each pixel's jitter and the
// cssm seed, and the engine returns the mean of the samples so far, converging to the noise-free image.
#pragma once

#include <nlohmann/json.hpp>

#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/render/renderer.h"
#include "penumbra/scene_io/scene_file.h"

namespace penumbra {

// Caller-owned outputs of a frame, each width × height pixels in row order (empty spans are skipped).
struct FrameBuffers {
  std::span<float> rgba;           // linear RGB and alpha, premultiplied, 4 floats a pixel
  std::span<std::uint8_t> srgb8;   // sRGB-encoded RGBA (straight alpha), 4 bytes a pixel
  std::span<float> depth;          // distance along the primary ray (FrameResult::depth); infinity: nothing
  bool transparent_background = false;  // the background is alpha 0 instead of the scene's colour
};

struct FrameOptions {
  Quality quality = Quality::Full;
  bool accumulate = true;                       // full frames of an unchanged scene average their samples
  const std::atomic<bool>* cancel = nullptr;   // set from another thread: render() throws Cancelled
  FrameBuffers* buffers = nullptr;
  // false: a preview's image (and alpha, depth) stays at 1/divisor of each side instead of being
  // enlarged to the camera's size (the viewer sends it so, and the browser scales it)
  bool enlarge_preview = true;
};

struct RebuiltStructure {
  std::string structure;  // render/renderer.h's name, e.g. "lights.0.shadows"
  std::string cause;      // the edited path, "refine" (built coarser for a preview), "sample" (a new cssm
                          // seed), "first frame", or "needed" (the edited scene asks for it)
};

struct EngineFrame {
  Image image;                   // the mean of the accumulated samples (the frame itself when one)
  FrameResult frame;             // the last sample's frame: timings, depth, stats; its alpha is the mean
                                 // of the samples' (as `image` is); its image is moved into `image` (and
                                 // empty) when the image is that one sample
  int samples = 1;               // how many samples the image averages
  int divisor = 1;               // a preview's image was rendered at 1/divisor of each side
  std::vector<RebuiltStructure> rebuilt;
  std::vector<std::string> edits;  // the paths edited since the previous frame
};

class Engine {
public:
  // A scene document and the folder its relative paths resolve against.
  // `options.strict` holds for every edit too; options.cache (data loaded before, e.g. by data_scene)
  // and options.arrays are copied: the engine shares their data.
  Engine(nlohmann::json document, std::string base_dir, const SceneReadOptions& options = {});
  static Engine open(const std::string& scene_file, const std::vector<std::string>& overrides = {}, const SceneReadOptions& options = {});

  // Applies the edits together (paths as `--set`; values JSON). Error naming the path and what was
  // expected when a path is unknown or the edited scene is invalid; the engine then keeps its scene.
  void edit(const std::vector<std::pair<std::string, nlohmann::json>>& edits);
  void set(const std::string& path, const nlohmann::json& value) { edit({{path, value}}); }
  // Replaces in-memory data that the document names by "array" (scene_file.h): every object naming it is
  // rebuilt as after an edit of its definition (particles: spheres, BVH, shadows, ambient occlusion),
  // the cause being "particles.N" or "volumes.N". What a trajectory player calls once a frame.
  void replace_array(const std::string& name, std::shared_ptr<const ParticleSet> particles);
  void replace_array(const std::string& name, std::shared_ptr<const Volume> volume);
  // The document as a scene file saved in `folder` says it: file paths relative to that folder, and the
  // transfer functions chosen from the data (for volumes that came without one) written out, so that
  // `penumbra render` of the saved file gives this engine's image.
  nlohmann::json saved_document(const std::string& folder) const;
  // Every file that the data files read from now on name (an NRRD header's data file, a DICOM folder's
  // slices) must lie inside `folder`, given canonical: the viewer's data root. The files the document
  // names are the caller's to check.
  void confine_files_to(std::string folder) { confine_to_ = std::move(folder); }
  // The value at a path: the document's, else the default the scene's read took (null where the default
  // is worked out from the data or the scene and has no fixed value). Error for a path that is
  // neither, naming the keys its object has.
  nlohmann::json get(const std::string& path) const;
  // Whether the document sets the path (false for defaults; Error for an unknown path, as get).
  bool is_set(const std::string& path) const;

  EngineFrame render(const FrameOptions& options = {});

  const Scene& scene() const { return renderer_->scene(); }
  const nlohmann::json& document() const { return document_; }
  const std::string& base_dir() const { return base_dir_; }  // where the document's relative paths lead
  const Renderer& renderer() const { return *renderer_; }
  int accumulated_samples() const { return samples_; }

private:
  // Reads the edited document and makes stale what the edited paths invalidate.
  void apply(nlohmann::json edited, const std::vector<std::string>& paths);
  void replace_array(const std::string& name, const char* kind);
  // Options for reading the document: the defaults it takes land in `defaults` (null: not noted).
  SceneReadOptions read_options(ReadDefaults* defaults = nullptr) {
    SceneReadOptions o{strict_, &cache_, arrays_ ? &*arrays_ : nullptr};
    o.defaults = defaults;
    o.confine_to = confine_to_;
    return o;
  }
  const nlohmann::json* document_value(const std::string& path) const;  // null when the document lacks it

  nlohmann::json document_;
  std::string base_dir_;
  bool strict_ = false;
  SceneDataCache cache_;
  std::optional<SceneArrays> arrays_;  // what "array" names, when the caller gave any
  std::string confine_to_;             // confine_files_to's folder ("" none)
  std::unique_ptr<Renderer> renderer_;
  std::map<std::string, std::string> causes_;  // stale structure → the path that made it stale
  std::vector<std::string> edits_;             // paths edited since the last frame
  ReadDefaults defaults_;                      // the defaults the document's last read took
  bool new_renderer_ = true;
  // accumulation
  std::vector<Rgb> sum_;        // the accumulated samples' colour (over the background) ...
  std::vector<float> alpha_sum_;  // ... and coverage: their means are a premultiplied frame's mean
  int samples_ = 0;
  Quality last_quality_ = Quality::Full;
  double full_render_ms_ = 0;  // the last full frame's render time: sizes the preview
};

// Writes a frame's image, alpha and depth into the caller's buffers.
void write_frame_buffers(const Image& image, const FrameResult& frame, const Rgb& background, FrameBuffers& out);

}  // namespace penumbra
