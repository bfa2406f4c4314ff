// The compiled half of the Python package (python/penumbra/__init__.py is the other): the interactive
// engine (engine/engine.h) with NumPy buffers. Scene documents cross as JSON text, so the Python side
// takes exactly the scene-file schema; the arrays its builders add cross as SceneArrays (a volume is a
// view of the NumPy array, no copy; spheres are packed once); frames are written straight into the
// NumPy array the caller gets back (no copy of the frame); the GIL is released while a frame renders.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdint>
#include <cstring>
#include <exception>
#include <filesystem>
#include <functional>
#include <limits>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "penumbra/core/parallel.h"
#include "penumbra/registry/technique_catalog.h"
#include "penumbra/core/cancel.h"
#include "penumbra/core/byte_size.h"
#include "penumbra/core/error.h"
#include "penumbra/core/frame_memory.h"
#include "penumbra/core/image.h"
#include "penumbra/data/elements.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/engine/engine.h"
#include "penumbra/scene_io/json_reader.h"
#include "penumbra/scene_io/scene_file.h"
#include "penumbra/core/timer.h"
#include "penumbra/viewer/frame_message.h"
#include "penumbra/viewer/probe.h"
#include "penumbra/viewer/viewer_page.h"
#include "penumbra/viewer/viewer_server.h"
#include "penumbra/viewer/viewer_state.h"

namespace py = pybind11;
using namespace penumbra;

namespace {

nlohmann::json parse(const std::string& text, const std::string& what) { return parse_json_text(text, what); }

// The stats of a frame, as the CLI's --stats names them.
nlohmann::json frame_stats(const EngineFrame& f, const Renderer& renderer) {
  const Scene& scene = renderer.scene();
  const FrameResult& r = f.frame;
  nlohmann::json rebuilt = nlohmann::json::array();
  for (const auto& s : f.rebuilt) rebuilt.push_back({{"structure", s.structure}, {"cause", s.cause}});
  // per particle set: the spheres drawn (none for a hidden set), whether it is shown, and the atoms its
  // `select` kept (None without one)
  nlohmann::json particles = nlohmann::json::array();
  for (const ParticleObject& p : scene.particles)
    particles.push_back({{"spheres", p.visible ? p.set->size() : 0}, {"visible", p.visible},
                         {"selected", p.selected_atoms ? nlohmann::json(*p.selected_atoms) : nlohmann::json(nullptr)}});
  std::size_t volume_bytes = 0;
  for (const auto& v : scene.volumes) volume_bytes += v.volume->memory_bytes();
  // each pyramid drawn from a finer box (render/view_refinement.h), as `penumbra render --stats` lists it
  const nlohmann::json refinement = refinement_json(r.refinement);
  nlohmann::json gradients = nlohmann::json::array();
  for (const bool stored : renderer.volume_gradients_stored()) gradients.push_back(stored ? "stored" : "on_the_fly");
  return {{"particles", particles},
          {"memory_bytes",
           {{"volume", volume_bytes}, {"volume_structures", renderer.volume_structure_memory_bytes()},
            {"shadow", renderer.shadow_memory_bytes()}, {"ambient", renderer.ambient_memory_bytes()}, {"sat", renderer.sat_memory_bytes()},
            {"particles", renderer.particle_memory_bytes()}, {"bvh", renderer.bvh_memory_bytes()},
            {"light_cache", renderer.light_cache_memory_bytes()}, {"refined", renderer.refined_memory_bytes()}}},
          {"gradients", gradients},
          {"refinement", refinement},
          {"counts", {{"volume_samples", r.volume_samples}, {"volume_shaded_samples", r.volume_shaded_samples}, {"sphere_pixels", r.sphere_pixels},
                      {"ambient_kept", r.ambient_kept}}},
          {"surfaces_kept", r.surfaces_kept},
          {"throughput",
           {{"samples_per_second", static_cast<double>(r.volume_samples) / (std::max(r.render_ms, 1e-3) / 1000.0)},
            {"sphere_pixels_per_second", static_cast<double>(r.sphere_pixels) / (std::max(r.render_ms, 1e-3) / 1000.0)}}},
          {"timings_ms",
           {{"prepare", r.prepare_ms}, {"sat", r.sat_ms}, {"ambient", r.ambient_ms}, {"build", r.build_ms},
            {"render", r.render_ms}, {"hits", r.hits_ms}, {"bvh", r.bvh_ms}, {"total", r.total_ms}}},
          {"rebuilt", rebuilt},
          {"edits", f.edits},
          {"quality", to_string(r.quality)},
          {"samples", f.samples},
          {"width", f.image.width()},
          {"height", f.image.height()}};
}

// A C-contiguous NumPy volume (axes z, y, x: x varies fastest) viewed in place. The volume holds a
// reference to the array, released with the GIL held when the last copy of the volume goes.
std::shared_ptr<const Volume> view_volume(const std::string& name, const py::array& a) {
  const std::string where = "volume array \"" + name + "\"";
  ScalarType type;
  if (py::isinstance<py::array_t<std::uint8_t>>(a)) type = ScalarType::UInt8;
  else if (py::isinstance<py::array_t<std::int16_t>>(a)) type = ScalarType::Int16;
  else if (py::isinstance<py::array_t<std::uint16_t>>(a)) type = ScalarType::UInt16;
  else if (py::isinstance<py::array_t<float>>(a)) type = ScalarType::Float32;
  else throw Error(where + ": dtype " + py::str(a.dtype()).cast<std::string>() + " (expected uint8, int16, uint16 or float32 in native byte order)");
  if (a.ndim() != 3) throw Error(where + ": " + std::to_string(a.ndim()) + " dimensions (expected 3: z, y, x)");
  if (!(a.flags() & py::array::c_style)) throw Error(where + ": not C-contiguous");
  for (int d = 0; d < 3; ++d)
    if (a.shape(d) > std::numeric_limits<int>::max()) throw Error(where + ": axis " + std::to_string(d) + " is too long");
  auto* held = new py::object(a);
  std::shared_ptr<const void> owner(held->ptr(), [held](const void*) {
    if (!Py_IsInitialized()) return;  // the interpreter is gone: nothing left to release
    py::gil_scoped_acquire gil;
    delete held;
  });
  const std::array<int, 3> dims{static_cast<int>(a.shape(2)), static_cast<int>(a.shape(1)), static_cast<int>(a.shape(0))};
  return with_context(where, [&] {
    return std::make_shared<const Volume>(Volume::view(type, dims, static_cast<const std::byte*>(a.data()), std::move(owner)));
  });
}

using SphereArray = py::array_t<float, py::array::c_style | py::array::forcecast>;
using ColorArray = py::array_t<float, py::array::c_style | py::array::forcecast>;

// Spheres (N, 4: x, y, z, radius) and linear RGB colours (N, 3) as a particle set (one copy).
std::shared_ptr<const ParticleSet> pack_particles(const std::string& name, const SphereArray& spheres, const ColorArray& colors) {
  const std::string where = "particle array \"" + name + "\"";
  if (spheres.ndim() != 2 || spheres.shape(1) != 4) throw Error(where + ": expected (N, 4) spheres");
  if (colors.ndim() != 2 || colors.shape(0) != spheres.shape(0) || colors.shape(1) != 3) throw Error(where + ": expected (N, 3) colours");
  auto set = std::make_shared<ParticleSet>();
  const auto n = static_cast<std::size_t>(spheres.shape(0));
  set->spheres.resize(n);
  set->colors.resize(n);
  const float* rgb = colors.data();
  for (std::size_t i = 0; i < n; ++i) set->colors[i] = pack_rgba8(Rgb(rgb[3 * i], rgb[3 * i + 1], rgb[3 * i + 2]));
  const float* xyzr = spheres.data();
  for (std::size_t i = 0; i < n; ++i) {
    Sphere& sp = set->spheres[i];
    sp = Sphere{{xyzr[4 * i], xyzr[4 * i + 1], xyzr[4 * i + 2]}, xyzr[4 * i + 3]};
    if (!is_finite(sp.center) || !std::isfinite(sp.radius) || !(sp.radius > 0))
      throw Error(where + ": sphere " + std::to_string(i) + " has centre (" + std::to_string(sp.center.x) + ", " + std::to_string(sp.center.y) + ", " +
                  std::to_string(sp.center.z) + ") and radius " + std::to_string(sp.radius) + " (expected finite numbers and a positive radius)");
  }
  return set;
}

// The builders' arrays by name: {name: ndarray} volumes, {name: (spheres, colours)} particles.
SceneArrays scene_arrays(const py::dict& volumes, const py::dict& particles) {
  SceneArrays a;
  for (const auto& [name, array] : volumes) a.volumes[name.cast<std::string>()] = view_volume(name.cast<std::string>(), array.cast<py::array>());
  for (const auto& [name, pair] : particles) {
    const auto t = pair.cast<py::tuple>();
    const std::string n = name.cast<std::string>();
    a.particles[n] = pack_particles(n, t[0].cast<SphereArray>(), t[1].cast<ColorArray>());
    a.particle_framing[n] = a.particles[n]->bounds();  // the camera frames these, however they move later
  }
  return a;
}

SceneReadOptions read_options(const SceneArrays& arrays) {
  SceneReadOptions o;
  o.arrays = &arrays;
  return o;
}

// The engine over NumPy buffers. One engine may be shared by Python threads: every call holds the
// engine's mutex, waited for with the GIL released (a thread rendering with the GIL released must be
// able to finish), so frames and edits are serialised and never interleave.
class PyEngine {
public:
  PyEngine(const std::string& document, const std::string& base_dir, const py::dict& volumes, const py::dict& particles)
      : engine_(parse(document, "scene"), base_dir, read_options(scene_arrays(volumes, particles))) {}

  void replace_volume(const std::string& name, const py::array& array) {
    const auto lock = locked();
    engine_.replace_array(name, view_volume(name, array));
  }
  void replace_particles(const std::string& name, const SphereArray& spheres, const ColorArray& colors) {
    const auto lock = locked();
    engine_.replace_array(name, pack_particles(name, spheres, colors));
  }

  void edit(const std::vector<std::pair<std::string, std::string>>& edits) {
    std::vector<std::pair<std::string, nlohmann::json>> parsed;
    for (const auto& [path, text] : edits) parsed.emplace_back(path, parse(text, path));
    const auto lock = locked();
    engine_.edit(parsed);
  }
  std::string get(const std::string& path) const {
    const auto lock = locked();
    return engine_.get(path).dump();
  }
  bool is_set(const std::string& path) const {
    const auto lock = locked();
    return engine_.is_set(path);
  }
  // Where the renderer reads volume `index`'s voxels (for checking that an array is shared, not copied).
  std::uintptr_t volume_address(std::size_t index) const {
    const auto lock = locked();
    const auto& volumes = engine_.scene().volumes;
    if (index >= volumes.size()) throw Error("volumes." + std::to_string(index) + ": no such volume (the scene has " + std::to_string(volumes.size()) + ")");
    return reinterpret_cast<std::uintptr_t>(volumes[index].volume->data());
  }
  std::string document() const {
    const auto lock = locked();
    return engine_.document().dump();
  }
  // The scene as a file saved in `folder` would say it (Engine::saved_document), as indented JSON text.
  std::string saved_document(const std::string& folder) const {
    const auto lock = locked();
    return engine_.saved_document(folder).dump(2) + "\n";
  }
  int width() const {
    const auto lock = locked();
    return engine_.scene().camera.width;
  }
  int height() const {
    const auto lock = locked();
    return engine_.scene().camera.height;
  }
  std::size_t frames() const {
    const auto lock = locked();
    return engine_.scene().frame_count();
  }

  // Renders into `out` ((H, W, 4) float32 premultiplied linear RGBA, or uint8 sRGB RGBA); returns the
  // frame's stats as JSON text.
  std::string render_into(py::array out, bool preview, bool accumulate, bool transparent) {
    const auto lock = locked();
    const auto h = static_cast<py::ssize_t>(engine_.scene().camera.height), w = static_cast<py::ssize_t>(engine_.scene().camera.width);
    if (out.ndim() != 3 || out.shape(0) != h || out.shape(1) != w || out.shape(2) != 4)
      throw Error("render: the output array must have shape (" + std::to_string(h) + ", " + std::to_string(w) + ", 4)");
    if (!(out.flags() & py::array::c_style)) throw Error("render: the output array must be C-contiguous");
    FrameBuffers buffers;
    buffers.transparent_background = transparent;
    const auto n = static_cast<std::size_t>(h * w * 4);
    if (py::isinstance<py::array_t<float>>(out)) buffers.rgba = std::span<float>(static_cast<float*>(out.mutable_data()), n);
    else if (py::isinstance<py::array_t<std::uint8_t>>(out)) buffers.srgb8 = std::span<std::uint8_t>(static_cast<std::uint8_t*>(out.mutable_data()), n);
    else throw Error("render: dtype must be float32 or uint8");
    FrameOptions options;
    options.quality = preview ? Quality::Preview : Quality::Full;
    options.accumulate = accumulate;
    options.buffers = &buffers;
    const EngineFrame f = render_interruptibly(options);
    return frame_stats(f, engine_.renderer()).dump();
  }

  // For the notebook widget (python/penumbra/widget.py), which speaks the viewer's protocol
  // (docs/viewer.md) over the kernel's comm. The "state" message for the scene as it is now, as text.
  std::string viewer_state() {
    const auto lock = locked();
    return viewer_state_.message(engine_).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  }
  // A frame as the page takes it: (the "frame" message as text, the JPEG), a preview at its reduced size.
  // `generation` is cancel_generation() as the caller read it before deciding to render: a cancel_frame()
  // since then (from any thread) stops the frame, which returns None (before it starts, or within a
  // chunk's time), so that an edit never waits behind a frame made stale by it.
  py::object frame_message(bool preview, bool accumulate, int max_samples, std::uint64_t generation) {
    std::string meta;
    py::bytes jpeg;
    {
      const auto lock = locked();
      if (cancel_generation_ != generation) return py::none();
      FrameOptions options;
      options.quality = preview ? Quality::Preview : Quality::Full;
      options.accumulate = accumulate;
      options.enlarge_preview = false;
      Timer timer;
      EngineFrame f;
      try {
        f = render_interruptibly(options, [&] { return cancel_generation_ != generation; });
      } catch (const Cancelled&) {
        return py::none();
      }
      FrameMessage m = penumbra::frame_message(f, options.quality, engine_.scene(), timer.elapsed_ms(), max_samples);
      meta = m.meta.dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
      jpeg = py::bytes(m.jpeg);
    }
    return py::make_tuple(meta, jpeg);
  }
  // Stops the frame_message() in progress, and any that a caller decided on before this call; without a lock.
  void cancel_frame() { ++cancel_generation_; }
  std::uint64_t cancel_generation() const { return cancel_generation_; }
  // The answer to the page's "probe" message (its JSON text): the value under the pointer.
  std::string probe(const std::string& message) {
    const std::pair<float, float> pixel = probe_pixel(parse(message, "probe"));
    const auto lock = locked();
    return probe_message(engine_.scene(), pixel.first, pixel.second).dump(-1, ' ', false, nlohmann::json::error_handler_t::replace);
  }

private:
  // Renders on a worker thread while this one, with the GIL released but for a moment every 20 ms,
  // lets Python run its signal handlers: Ctrl-C (or any handler that raises) cancels the frame, which
  // stops within a chunk's time (core/cancel.h), and the handler's exception (KeyboardInterrupt) is
  // raised here once the worker has let go of the engine. The engine is left as after a cancelled
  // viewer frame: the next render starts afresh.
  // `stale`, when given, cancels the frame too once it says so (asked as often as the signals are checked).
  EngineFrame render_interruptibly(FrameOptions options, const std::function<bool()>& stale = {}) {
    std::atomic<bool> cancel{false};
    options.cancel = &cancel;
    EngineFrame frame;
    std::exception_ptr failure;
    bool interrupted = false;
    {
      py::gil_scoped_release release;
      std::mutex m;
      std::condition_variable finished;
      bool done = false;
      std::thread worker([&] {
        try {
          frame = engine_.render(options);
        } catch (...) {
          failure = std::current_exception();
        }
        const std::lock_guard<std::mutex> g(m);
        done = true;
        finished.notify_one();
      });
      std::unique_lock<std::mutex> lock(m);
      while (!finished.wait_for(lock, std::chrono::milliseconds(20), [&] { return done; })) {
        if (stale && stale()) cancel = true;
        if (interrupted) continue;
        lock.unlock();
        {
          py::gil_scoped_acquire acquire;
          interrupted = PyErr_CheckSignals() != 0;  // the handler's exception stays set
        }
        if (interrupted) cancel = true;
        lock.lock();
      }
      lock.unlock();
      worker.join();
    }
    if (interrupted) throw py::error_already_set();
    if (failure) std::rethrow_exception(failure);
    return frame;
  }

  // The engine's lock, taken with the GIL released while waiting, and held until the call returns.
  std::unique_lock<std::mutex> locked() const {
    std::unique_lock<std::mutex> lock(mutex_, std::try_to_lock);
    if (!lock.owns_lock()) {
      py::gil_scoped_release release;
      lock.lock();
    }
    return lock;
  }

  Engine engine_;
  ViewerState viewer_state_;  // keeps each volume's histogram between state messages
  std::atomic<std::uint64_t> cancel_generation_{0};
  mutable std::mutex mutex_;
};

// `penumbra view` inside Python: the viewer's server over its own engine, serving from a thread
// until stop() (docs/viewer.md).
class PyViewer {
public:
  PyViewer(const std::string& document, const std::string& base_dir, const py::dict& volumes, const py::dict& particles,
           const std::string& host, int port, const std::string& data_root, const std::string& token,
           const std::vector<std::string>& frame_ancestors) {
    ViewerOptions options;
    options.frame_ancestors = frame_ancestors;
    options.host = host;
    if (port < 0 || port > 65535) throw Error("view: port " + std::to_string(port) + " (expected 0-65535)");
    options.port = static_cast<std::uint16_t>(port);
    options.data_root = data_root;
    options.token = token;
    options.stop_on_signals = false;  // Ctrl-C belongs to Python
    server_ = std::make_unique<ViewerServer>(Engine(parse(document, "scene"), base_dir, read_options(scene_arrays(volumes, particles))), options);
    thread_ = std::thread([this] { server_->run(); });
  }
  ~PyViewer() { stop(); }
  std::string url() const { return server_->url(); }
  void stop() {
    if (!thread_.joinable()) return;
    py::gil_scoped_release release;  // the render thread may need the GIL to let go of an array
    server_->stop();
    thread_.join();
  }

private:
  std::unique_ptr<ViewerServer> server_;
  std::thread thread_;
};

}  // namespace

PYBIND11_MODULE(_penumbra, m) {
  keep_frame_memory_mapped();  // before the first frame: see core/frame_memory.h
  m.doc() = "penumbra's compiled core: the interactive engine over NumPy buffers (use the penumbra package)";
  static py::exception<Error> error(m, "Error", PyExc_ValueError);
  py::register_exception_translator([](std::exception_ptr p) {
    try {
      if (p) std::rethrow_exception(p);
    } catch (const Cancelled& e) {
      PyErr_SetString(PyExc_KeyboardInterrupt, e.what());
    } catch (const Error& e) {
      error(e.what());
    }
  });

  // The shadow and ambient techniques with the keys each declares (lighting/technique_info.h).
  m.def("techniques", [] {
    py::list out;
    for (const TechniqueInfo* t : technique_catalog()) {
      py::list keys;
      for (const ParamSpec& p : t->params) {
        py::dict k;
        k["key"] = p.key;
        k["type"] = p.type_text();
        if (p.type == ParamType::Choice) k["default"] = p.default_choice;
        else if (p.type == ParamType::Integer) k["default"] = static_cast<std::int64_t>(p.default_number);
        else k["default"] = p.default_number;
        k["allowed"] = p.allowed_text();
        k["unit"] = p.unit;
        k["meaning"] = p.meaning;
        keys.append(k);
      }
      py::list casters;
      for (int i = 0; i < kObjectKinds; ++i)
        if (t->casters & kind_bit(static_cast<ObjectKind>(i))) casters.append(to_string(static_cast<ObjectKind>(i)));
      py::dict d;
      d["name"] = t->name;
      d["family"] = to_string(t->family);
      d["casters"] = casters;
      d["summary"] = t->summary;
      d["keys"] = keys;
      out.append(d);
    }
    return out;
  });
  // The scene document of a file with `--set` overrides applied, and the folder its paths resolve against.
  m.def("load_document", [](const std::string& path, const std::vector<std::string>& overrides) {
    nlohmann::json j = read_json_file(path);
    with_context(path, [&] { for (const auto& o : overrides) apply_override(j, o); });
    return py::make_tuple(j.dump(), std::filesystem::path(path).parent_path().string());
  });
  // Reads the document exactly as a scene file (loads the data); Error naming the key when invalid.
  m.def("validate", [](const std::string& document, const std::string& base_dir, const py::dict& volumes, const py::dict& particles) {
    const SceneArrays arrays = scene_arrays(volumes, particles);
    (void)build_scene(parse(document, "scene"), base_dir, read_options(arrays));
  }, py::arg("document"), py::arg("base_dir"), py::arg("volumes") = py::dict(), py::arg("particles") = py::dict());
  // A volume file (or the slices of a DICOM series) read as the renderer reads it: a NumPy copy of its
  // voxels (axes z, y, x), spacing and origin (x, y, z) and what the reader found, as JSON text.
  m.def("read_volume", [](const std::vector<std::string>& paths, const std::string& series, int channel, const std::string& grid, int level,
                          const std::string& dataset, const std::string& memory_budget) {
    VolumeLoadOptions lo;
    if (!memory_budget.empty()) lo.memory_budget = parse_byte_size(memory_budget);
    lo.dataset = dataset;
    lo.series = series;
    lo.channel = channel;
    lo.grid = grid;
    lo.level = level;
    VolumeFileInfo info;
    Volume v;
    {
      py::gil_scoped_release release;
      v = load_volume(paths, lo, &info);
    }
    const std::vector<py::ssize_t> shape{v.dims()[2], v.dims()[1], v.dims()[0]};
    py::array array = v.with_voxel_type([&](auto t) -> py::array {
      using T = decltype(t);
      py::array_t<T> a(shape);
      if (!v.is_bricked()) {
        std::memcpy(a.mutable_data(), v.data(), v.voxel_count() * sizeof(T));
        return a;
      }
      // A sparse (bricked) volume becomes a dense array: NumPy has no sparse layout to hand it in.
      T* out = a.mutable_data();
      const auto& d = v.dims();
      for (int k = 0; k < d[2]; ++k)
        for (int j = 0; j < d[1]; ++j)
          for (int i = 0; i < d[0]; ++i) *out++ = static_cast<T>(v.value(i, j, k));
      return a;
    });
    nlohmann::json affine;  // the file's index-to-world transform (LPS), rows of [linear | offset], or null
    if (info.affine)
      for (int r = 0; r < 3; ++r)
        affine.push_back({info.affine->linear[r][0], info.affine->linear[r][1], info.affine->linear[r][2], info.affine->offset[r]});
    const nlohmann::json described = {{"format", info.format}, {"affine", affine}, {"orientation", info.orientation}, {"series", info.series},
                                      {"series_index", info.series_index}, {"channels", info.channels},
                                      {"channel", info.channel}, {"notes", info.notes}};
    return py::make_tuple(array, py::make_tuple(v.spacing().x, v.spacing().y, v.spacing().z),
                          py::make_tuple(v.origin().x, v.origin().y, v.origin().z), described.dump());
  }, py::arg("paths"), py::arg("series") = "", py::arg("channel") = -1, py::arg("grid") = "", py::arg("level") = -1, py::arg("dataset") = "",
     py::arg("memory_budget") = "");
  // Van der Waals radius (Å) and CPK colour (linear RGB) of each element symbol; unknown: 1.7 Å, grey.
  m.def("element_style", [](const std::vector<std::string>& symbols) {
    py::array_t<float> radii(static_cast<py::ssize_t>(symbols.size()));
    py::array_t<float> colors({static_cast<py::ssize_t>(symbols.size()), py::ssize_t{3}});
    auto r = radii.mutable_unchecked<1>();
    auto c = colors.mutable_unchecked<2>();
    for (std::size_t i = 0; i < symbols.size(); ++i) {
      const int e = element_from_symbol(symbols[i]);
      const auto k = static_cast<py::ssize_t>(i);
      r(k) = element_vdw_radius(e);
      const Rgb rgb = element_color(e);
      c(k, 0) = rgb.r;
      c(k, 1) = rgb.g;
      c(k, 2) = rgb.b;
    }
    return py::make_tuple(radii, colors);
  });

  // A 64-bit digest of an array's bytes that changes when any byte does, or when two words swap: each
  // 8-byte word is mixed with its position (splitmix64's finaliser) and the mixes XORed, so every core
  // takes a share. What tells the package that a volume's array was changed in place without
  // update_volume (docs/python.md gives its cost).
  m.def("digest", [](const py::buffer& buffer) {
    const py::buffer_info info = buffer.request();
    if (info.strides.size() > 0 && info.itemsize * info.size > 0) {
      py::ssize_t expected = info.itemsize;
      for (std::size_t d = info.shape.size(); d-- > 0;) {
        if (info.strides[d] != expected) throw Error("digest: the array must be C-contiguous");
        expected *= info.shape[d];
      }
    }
    const auto* bytes = static_cast<const unsigned char*>(info.ptr);
    const std::size_t size = static_cast<std::size_t>(info.itemsize * info.size);
    const auto mix = [](std::uint64_t z) {
      z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ull;
      z = (z ^ (z >> 27)) * 0x94d049bb133111ebull;
      return z ^ (z >> 31);
    };
    std::atomic<std::uint64_t> digest{mix(size)};
    py::gil_scoped_release release;
    const std::size_t words = size / 8;
    parallel_for((words + 65535) / 65536, [&](std::size_t c0, std::size_t c1) {
      std::uint64_t local = 0;
      for (std::size_t w = c0 * 65536; w < std::min(words, c1 * 65536); ++w) {
        std::uint64_t v;
        std::memcpy(&v, bytes + 8 * w, 8);
        local ^= mix(v + 0x9e3779b97f4a7c15ull * (w + 1));
      }
      digest.fetch_xor(local, std::memory_order_relaxed);
    });
    std::uint64_t tail = 0;
    std::memcpy(&tail, bytes + 8 * words, size - 8 * words);
    return digest.load() ^ mix(tail + 0x9e3779b97f4a7c15ull * (words + 1));
  }, py::arg("array"));

  // The worker threads of every frame (0: one per core), until set again.
  m.def("set_threads", [](int threads) {
    static std::unique_ptr<ThreadLimit> limit;
    if (threads < 0) throw Error("set_threads: " + std::to_string(threads) + " (expected 0 for one per core, or a count)");
    py::gil_scoped_release release;
    limit.reset();
    if (threads > 0) limit = std::make_unique<ThreadLimit>(threads);
  }, py::arg("threads"));
  m.def("threads", [] { return ThreadLimit::current_max(); });

  py::class_<PyEngine>(m, "Engine")
      .def(py::init<const std::string&, const std::string&, const py::dict&, const py::dict&>(), py::arg("document"), py::arg("base_dir"),
           py::arg("volumes") = py::dict(), py::arg("particles") = py::dict())
      .def("replace_volume", &PyEngine::replace_volume, "The volume array of that name is now this one (or the same one, changed in place)")
      .def("replace_particles", &PyEngine::replace_particles, "The particle array of that name is now these spheres and colours")
      .def("edit", &PyEngine::edit, "Edits [(path, JSON text)] together; Error naming the path when refused")
      .def("get", &PyEngine::get)
      .def("is_set", &PyEngine::is_set)
      .def("volume_address", &PyEngine::volume_address)
      .def("document", &PyEngine::document)
      .def("saved_document", &PyEngine::saved_document, py::arg("folder"))
      .def_property_readonly("width", &PyEngine::width)
      .def_property_readonly("height", &PyEngine::height)
      .def_property_readonly("frames", &PyEngine::frames)
      .def("render_into", &PyEngine::render_into, py::arg("out"), py::arg("preview") = false, py::arg("accumulate") = false,
           py::arg("transparent") = false)
      .def("viewer_state", &PyEngine::viewer_state, "The viewer's state message (docs/viewer.md) as JSON text")
      .def("frame_message", &PyEngine::frame_message, py::arg("preview"), py::arg("accumulate"), py::arg("max_samples"),
           py::arg("generation"), "(frame message JSON text, JPEG bytes), or None when cancel_frame() stopped it")
      .def("cancel_frame", &PyEngine::cancel_frame)
      .def("cancel_generation", &PyEngine::cancel_generation)
      .def("probe", &PyEngine::probe, py::arg("message"));

  // The viewer's page as compiled in: {path: text} ("/" is index.html; "/style.css", "/js/main.js", ...).
  m.def("viewer_page_files", [] {
    py::dict files;
    for (const PageFile& f : viewer_page_files()) files[py::str(std::string(f.path))] = py::str(std::string(f.body));
    return files;
  });

  py::class_<PyViewer>(m, "Viewer")
      .def(py::init<const std::string&, const std::string&, const py::dict&, const py::dict&, const std::string&, int, const std::string&,
                    const std::string&, const std::vector<std::string>&>(),
           py::arg("document"), py::arg("base_dir"), py::arg("volumes"), py::arg("particles"), py::arg("host"), py::arg("port"),
           py::arg("data_root"), py::arg("token"), py::arg("frame_ancestors"))
      .def_property_readonly("url", &PyViewer::url)
      .def("stop", &PyViewer::stop);

  m.def("compare", [](py::array_t<float, py::array::c_style | py::array::forcecast> a, py::array_t<float, py::array::c_style | py::array::forcecast> b) {
    if (a.ndim() != 3 || b.ndim() != 3 || a.shape(2) < 3 || b.shape(2) < 3)
      throw Error("compare: expected two (H, W, 3 or 4) arrays");
    if (a.shape(0) != b.shape(0) || a.shape(1) != b.shape(1))
      throw Error("compare: the images differ in size (" + std::to_string(a.shape(1)) + "x" + std::to_string(a.shape(0)) + " and " +
                  std::to_string(b.shape(1)) + "x" + std::to_string(b.shape(0)) + ")");
    auto image = [](const py::array_t<float, py::array::c_style | py::array::forcecast>& x) {
      Image img(static_cast<int>(x.shape(1)), static_cast<int>(x.shape(0)));
      const auto c = x.shape(2);
      const float* d = x.data();
      for (py::ssize_t y = 0; y < x.shape(0); ++y)
        for (py::ssize_t i = 0; i < x.shape(1); ++i) {
          const float* p = d + (y * x.shape(1) + i) * c;
          img.at(static_cast<int>(i), static_cast<int>(y)) = Rgb(p[0], p[1], p[2]);
        }
      return img;
    };
    const ImageDifference d = compare_images(image(a), image(b));
    py::dict out;
    out["rmse"] = d.rmse;
    out["psnr"] = d.psnr;
    out["max_abs"] = d.max_abs;
    return out;
  });
}
