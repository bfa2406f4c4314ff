// The compiled half of the Python package (python/penumbra/__init__.py is the other): the interactive
// engine (engine/engine.h) with NumPy buffers. Scene documents cross as JSON text, so the Python side
// takes exactly the scene-file schema; frames are written straight into the NumPy array the caller
// gets back (no copy of the frame); the GIL is released while a frame renders.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <nlohmann/json.hpp>

#include <filesystem>
#include <string>
#include <vector>

#include "penumbra/core/cancel.h"
#include "penumbra/core/error.h"
#include "penumbra/core/image.h"
#include "penumbra/engine/engine.h"
#include "penumbra/scene/json_reader.h"
#include "penumbra/scene/scene_file.h"

namespace py = pybind11;
using namespace penumbra;

namespace {

nlohmann::json parse(const std::string& text, const std::string& what) { return parse_json_text(text, what); }

// The stats of a frame, as the CLI's --stats names them.
nlohmann::json frame_stats(const EngineFrame& f) {
  const FrameResult& r = f.frame;
  nlohmann::json rebuilt = nlohmann::json::array();
  for (const auto& s : f.rebuilt) rebuilt.push_back({{"structure", s.structure}, {"cause", s.cause}});
  return {{"timings_ms",
           {{"prepare", r.prepare_ms}, {"sat", r.sat_ms}, {"ambient", r.ambient_ms}, {"build", r.build_ms},
            {"render", r.render_ms}, {"bvh", r.bvh_ms}, {"total", r.total_ms}}},
          {"rebuilt", rebuilt},
          {"edits", f.edits},
          {"quality", to_string(r.quality)},
          {"samples", f.samples},
          {"width", f.image.width()},
          {"height", f.image.height()}};
}

class PyEngine {
public:
  PyEngine(const std::string& document, const std::string& base_dir) : engine_(parse(document, "scene"), base_dir) {}

  void edit(const std::vector<std::pair<std::string, std::string>>& edits) {
    std::vector<std::pair<std::string, nlohmann::json>> parsed;
    for (const auto& [path, text] : edits) parsed.emplace_back(path, parse(text, path));
    engine_.edit(parsed);
  }
  std::string get(const std::string& path) const { return engine_.get(path).dump(); }
  std::string document() const { return engine_.document().dump(); }
  int width() const { return engine_.scene().camera.width; }
  int height() const { return engine_.scene().camera.height; }

  // Renders into `out` ((H, W, 4) float32 premultiplied linear RGBA, or uint8 sRGB RGBA); returns the
  // frame's stats as JSON text.
  std::string render_into(py::array out, bool preview, bool accumulate, bool transparent) {
    const auto h = static_cast<py::ssize_t>(height()), w = static_cast<py::ssize_t>(width());
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
    EngineFrame f;
    {
      py::gil_scoped_release release;
      f = engine_.render(options);
    }
    return frame_stats(f).dump();
  }

private:
  Engine engine_;
};

}  // namespace

PYBIND11_MODULE(_penumbra, m) {
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

  // The scene document of a file with `--set` overrides applied, and the folder its paths resolve against.
  m.def("load_document", [](const std::string& path, const std::vector<std::string>& overrides) {
    nlohmann::json j = read_json_file(path);
    with_context(path, [&] { for (const auto& o : overrides) apply_override(j, o); });
    return py::make_tuple(j.dump(), std::filesystem::path(path).parent_path().string());
  });
  // Reads the document exactly as a scene file (loads the data); Error naming the key when invalid.
  m.def("validate", [](const std::string& document, const std::string& base_dir) {
    (void)build_scene(parse(document, "scene"), base_dir);
  });

  py::class_<PyEngine>(m, "Engine")
      .def(py::init<const std::string&, const std::string&>(), py::arg("document"), py::arg("base_dir"))
      .def("edit", &PyEngine::edit, "Edits [(path, JSON text)] together; Error naming the path when refused")
      .def("get", &PyEngine::get)
      .def("document", &PyEngine::document)
      .def_property_readonly("width", &PyEngine::width)
      .def_property_readonly("height", &PyEngine::height)
      .def("render_into", &PyEngine::render_into, py::arg("out"), py::arg("preview") = false, py::arg("accumulate") = false,
           py::arg("transparent") = false);

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
