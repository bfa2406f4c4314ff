// Transfer functions (transfer_function.h): validation and piecewise-linear evaluation, the built-in
// presets, the scene-file JSON form, ParaView colour-map import, opacity correction for the sampling step
// (alpha' = 1 - (1 - alpha)^(ds / reference_step), the usual "opacity correction" of DVR), and the
// lookup table with a prefix count of visible entries for empty-space skipping.
#include "penumbra/data/transfer_function.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "penumbra/core/error.h"
#include "penumbra/data/colormaps.h"

namespace penumbra {

namespace {

using nlohmann::json;


bool in_unit(float v) { return v >= 0.0f && v <= 1.0f; }  // false for NaN

// Presets are authored like ParaView's and Slicer's, in display (sRGB) colours; the renderer shades
// in linear RGB, so they are converted once here to look the same after the sRGB output transform.
TransferPoint srgb_point(float value, float r, float g, float b, float alpha) {
  return {value, Rgb(srgb_to_linear(r), srgb_to_linear(g), srgb_to_linear(b)), alpha};
}

// Preset control points. Alpha is per reference step (about one voxel), so bulk tissue that a ray
// crosses for a hundred voxels needs alphas of the order of 0.01 to stay see-through.
std::vector<TransferPoint> preset_points(const std::string& name) {
  if (name == "ct-bone")  // Hounsfield units; like ParaView's CT-Bone: reddish onset, ivory, white.
    return {srgb_point(-1024, 0.0f, 0.0f, 0.0f, 0.0f),   srgb_point(150, 0.73f, 0.25f, 0.30f, 0.0f),
            srgb_point(300, 0.86f, 0.62f, 0.48f, 0.15f), srgb_point(700, 0.93f, 0.86f, 0.68f, 0.75f),
            srgb_point(1500, 1.0f, 0.97f, 0.90f, 0.85f), srgb_point(3071, 1.0f, 1.0f, 1.0f, 0.90f)};
  if (name == "ct-soft-tissue")  // HU. The air/skin partial-volume band (-600..-300) is the visible skin
    // surface; bulk fat and muscle stay faint so the skull shows through as an opaque white layer.
    return {srgb_point(-1024, 0.0f, 0.0f, 0.0f, 0.0f),    srgb_point(-700, 0.55f, 0.25f, 0.15f, 0.0f),
            srgb_point(-450, 0.93f, 0.64f, 0.52f, 0.20f), srgb_point(-250, 0.92f, 0.62f, 0.50f, 0.03f),
            srgb_point(-100, 0.95f, 0.80f, 0.55f, 0.004f), srgb_point(40, 0.78f, 0.26f, 0.20f, 0.008f),
            srgb_point(120, 0.82f, 0.32f, 0.26f, 0.01f),  srgb_point(200, 0.90f, 0.82f, 0.72f, 0.10f),
            srgb_point(400, 0.96f, 0.93f, 0.86f, 0.85f),  srgb_point(3071, 1.0f, 1.0f, 1.0f, 0.95f)};
  if (name == "mri-head")  // normalised T1 (CSF ~0.15, grey matter ~0.4, white ~0.55, fat ~0.7): the
    // masked background is clear, the scalp a faint warm veil over the brain, white matter the densest.
    return {srgb_point(0.0f, 0.0f, 0.0f, 0.0f, 0.0f),      srgb_point(0.06f, 0.60f, 0.30f, 0.20f, 0.0f),
            srgb_point(0.15f, 0.80f, 0.50f, 0.40f, 0.01f),  srgb_point(0.30f, 0.90f, 0.62f, 0.52f, 0.02f),
            srgb_point(0.42f, 0.95f, 0.75f, 0.62f, 0.035f), srgb_point(0.55f, 1.0f, 0.90f, 0.78f, 0.08f),
            srgb_point(0.75f, 1.0f, 0.85f, 0.60f, 0.04f),   srgb_point(1.0f, 1.0f, 1.0f, 0.95f, 0.06f)};
  if (name == "test-spheres") {
    // Density domain of the procedural test-spheres volume: a plateau of +-0.04 around each sphere
    // density, fading to transparent 0.04 further out, so the 1.5-voxel edge ramps between densities
    // add little colour. The large faint spheres get small alphas so light passes through them tinted.
    struct Peak { float d, r, g, b, a; };
    constexpr std::array<Peak, 5> peaks{{{0.2f, 0.15f, 0.35f, 1.0f, 0.012f},
                                         {0.4f, 0.10f, 0.90f, 0.15f, 0.025f},
                                         {0.6f, 1.0f, 0.85f, 0.10f, 0.05f},
                                         {0.8f, 1.0f, 0.10f, 0.08f, 0.08f},
                                         {1.0f, 0.90f, 0.20f, 1.0f, 0.5f}}};
    std::vector<TransferPoint> pts{srgb_point(0.0f, 0.15f, 0.35f, 1.0f, 0.0f)};
    for (const Peak& p : peaks) {
      pts.push_back(srgb_point(p.d - 0.08f, p.r, p.g, p.b, 0.0f));
      pts.push_back(srgb_point(p.d - 0.04f, p.r, p.g, p.b, p.a));
      pts.push_back(srgb_point(std::min(p.d + 0.04f, 1.0f), p.r, p.g, p.b, p.a));
      if (p.d < 1.0f) pts.push_back(srgb_point(p.d + 0.08f, p.r, p.g, p.b, 0.0f));
    }
    return pts;
  }
  if (name == "grayscale") return {{0.0f, Rgb(0.0f), 0.0f}, {1.0f, Rgb(1.0f), 0.5f}};  // normalised
  if (const ColormapSamples* samples = colormap_samples(name)) {
    // A colour map over the normalised range, its opacity a ramp as grayscale's (and as ParaView gives
    // an imported colour map without opacity points).
    std::vector<TransferPoint> pts;
    for (std::size_t i = 0; i < samples->size(); ++i) {
      const float t = static_cast<float>(i) / static_cast<float>(samples->size() - 1);
      const auto& c = (*samples)[i];
      pts.push_back(srgb_point(t, c[0], c[1], c[2], 0.5f * t));
    }
    return pts;
  }
  std::string known;
  for (const std::string& n : transfer_function_preset_names()) known += (known.empty() ? "" : ", ") + n;
  throw Error("\"preset\": \"" + name + "\" is not a known preset (expected one of: " + known + ")");
}

bool preset_is_normalized(const std::string& name) {
  return name == "mri-head" || name == "grayscale" || colormap_samples(name) != nullptr;
}

float get_number(const json& j, const std::string& key) {
  if (!j.is_number()) throw Error("\"" + key + "\": " + j.dump() + " (expected a number)");
  const float v = j.get<float>();
  if (!std::isfinite(v)) throw Error("\"" + key + "\": " + j.dump() + " (expected a finite number)");
  return v;
}

// One scene-file point: [v, r, g, b, a] or {"value": v, "color": [r, g, b], "alpha": a}.
TransferPoint parse_point(const json& p, const std::string& where) {
  TransferPoint tp;
  if (p.is_array()) {
    if (p.size() != 5) throw Error(where + ": " + p.dump() + " (expected [value, r, g, b, alpha])");
    tp.value = get_number(p[0], where + "[0]");
    for (int c = 0; c < 3; ++c) tp.color[c] = get_number(p[static_cast<std::size_t>(c + 1)], where + "[" + std::to_string(c + 1) + "]");
    tp.alpha = get_number(p[4], where + "[4]");
    return tp;
  }
  if (!p.is_object())
    throw Error(where + ": " + p.dump() + " (expected [value, r, g, b, alpha] or {\"value\", \"color\", \"alpha\"})");
  for (const auto& [key, val] : p.items())
    if (key != "value" && key != "color" && key != "alpha")
      throw Error(where + ": unknown key \"" + key + "\" (expected value, color, alpha)");
  if (!p.contains("value") || !p.contains("color") || !p.contains("alpha"))
    throw Error(where + ": " + p.dump() + " (expected the keys value, color and alpha)");
  tp.value = get_number(p["value"], where + ".value");
  const json& c = p["color"];
  if (!c.is_array() || c.size() != 3) throw Error(where + ".color: " + c.dump() + " (expected [r, g, b])");
  for (int i = 0; i < 3; ++i) tp.color[i] = get_number(c[static_cast<std::size_t>(i)], where + ".color[" + std::to_string(i) + "]");
  tp.alpha = get_number(p["alpha"], where + ".alpha");
  return tp;
}

// A piecewise-linear function of N channels over sorted nodes (steps allowed), evaluated from the left
// and from the right so that the merge below keeps steps.
template <std::size_t N>
struct Pwl {
  std::vector<float> xs;
  std::vector<std::array<float, N>> ys;
  std::array<float, N> at(float x, bool from_left) const {
    const auto it = from_left ? std::lower_bound(xs.begin(), xs.end(), x) : std::upper_bound(xs.begin(), xs.end(), x);
    const std::size_t i = static_cast<std::size_t>(it - xs.begin());
    if (from_left && i < xs.size() && xs[i] == x) return ys[i];  // x is a node: its first value
    if (i == 0) return ys.front();
    if (i == xs.size()) return ys.back();
    const float t = (x - xs[i - 1]) / (xs[i] - xs[i - 1]);
    std::array<float, N> r{};
    for (std::size_t c = 0; c < N; ++c) r[c] = ys[i - 1][c] + (ys[i][c] - ys[i - 1][c]) * t;
    return r;
  }
};

// Reads ParaView's flat node list [x, c1, ..., c(stride-1), x, ...] into a Pwl, keeping the first
// `N` channels after x.
template <std::size_t N>
Pwl<N> read_nodes(const json& preset, const char* key, std::size_t stride) {
  const json& a = preset[key];
  if (!a.is_array()) throw Error(std::string("\"") + key + "\": expected an array of numbers");
  if (a.empty() || a.size() % stride != 0)
    throw Error(std::string("\"") + key + "\" has " + std::to_string(a.size()) + " numbers (expected a non-zero multiple of " +
                std::to_string(stride) + ")");
  std::vector<std::pair<float, std::array<float, N>>> nodes;
  for (std::size_t i = 0; i < a.size(); i += stride) {
    std::pair<float, std::array<float, N>> n;
    n.first = get_number(a[i], std::string(key) + "[" + std::to_string(i) + "]");
    for (std::size_t c = 0; c < N; ++c) {
      n.second[c] = get_number(a[i + 1 + c], std::string(key) + "[" + std::to_string(i + 1 + c) + "]");
      if (!in_unit(n.second[c]))
        throw Error(std::string("\"") + key + "\"[" + std::to_string(i + 1 + c) + "]: " + num(n.second[c]) + " (expected a value in [0, 1])");
    }
    nodes.push_back(n);
  }
  std::stable_sort(nodes.begin(), nodes.end(), [](const auto& l, const auto& r) { return l.first < r.first; });
  Pwl<N> f;
  for (const auto& n : nodes) { f.xs.push_back(n.first); f.ys.push_back(n.second); }
  return f;
}

}  // namespace

TransferFunction::TransferFunction(std::vector<TransferPoint> points) {
  if (points.empty()) throw Error("transfer function has no control points (expected at least one)");
  for (std::size_t i = 0; i < points.size(); ++i) {
    const TransferPoint& p = points[i];
    const std::string where = "transfer function point " + std::to_string(i) + " (value " + num(p.value) + ")";
    if (!std::isfinite(p.value)) throw Error(where + ": value is not finite (expected a finite number)");
    for (int c = 0; c < 3; ++c)
      if (!in_unit(p.color[c])) throw Error(where + ": colour component " + num(p.color[c]) + " (expected [0, 1])");
    if (!in_unit(p.alpha)) throw Error(where + ": alpha " + num(p.alpha) + " (expected [0, 1])");
  }
  // Stable, so two points with the same value keep their order and form a step.
  std::stable_sort(points.begin(), points.end(), [](const TransferPoint& a, const TransferPoint& b) { return a.value < b.value; });
  points_ = std::move(points);
}

Rgba TransferFunction::evaluate(float value) const {
  if (points_.empty()) return {};
  // First point strictly above value: at a step the later point wins (right-continuous).
  const auto it = std::upper_bound(points_.begin(), points_.end(), value,
                                   [](float v, const TransferPoint& p) { return v < p.value; });
  if (it == points_.begin() || std::isnan(value)) return {points_.front().color, points_.front().alpha};
  if (it == points_.end()) return {points_.back().color, points_.back().alpha};
  const TransferPoint& a = *(it - 1);
  const TransferPoint& b = *it;
  const float t = (value - a.value) / (b.value - a.value);
  return {a.color + (b.color - a.color) * t, a.alpha + (b.alpha - a.alpha) * t};
}

std::vector<std::string> transfer_function_preset_names() {
  std::vector<std::string> names{"ct-bone", "ct-soft-tissue", "mri-head", "test-spheres", "grayscale"};
  for (const std::string& c : colormap_names()) names.push_back(c);
  return names;
}

TransferFunction parse_transfer_function(const nlohmann::json& spec, float data_min, float data_max,
                                         const std::string& base_dir) {
  // A preset's name alone is that preset, as the Python builders and the viewer give it.
  if (spec.is_string()) return parse_transfer_function(nlohmann::json{{"preset", spec}}, data_min, data_max, base_dir);
  if (!spec.is_object()) throw Error("transfer function: " + spec.dump() + " (expected an object, or a preset's name)");
  for (const auto& [key, val] : spec.items())
    if (key != "preset" && key != "points" && key != "paraview" && key != "name" && key != "domain" && key != "opacity_scale")
      throw Error("transfer function: unknown key \"" + key + "\" (expected preset, points, paraview, name, domain, opacity_scale)");
  const int sources = int(spec.contains("preset")) + int(spec.contains("points")) + int(spec.contains("paraview"));
  if (sources != 1)
    throw Error("transfer function: " + spec.dump() + " (expected exactly one of \"preset\", \"points\", \"paraview\")");
  if (spec.contains("name") && !spec.contains("paraview"))
    throw Error("transfer function: \"name\" is only allowed with \"paraview\"");

  bool normalized = false;
  if (spec.contains("domain")) {
    const json& d = spec["domain"];
    if (spec.contains("preset"))
      throw Error("transfer function: \"domain\" is not allowed with \"preset\" (presets have a fixed domain)");
    if (!d.is_string() || (d != "data" && d != "normalized"))
      throw Error("transfer function: \"domain\": " + d.dump() + " (expected \"data\" or \"normalized\")");
    normalized = d == "normalized";
  }
  float opacity_scale = 1.0f;
  if (spec.contains("opacity_scale")) {
    opacity_scale = get_number(spec["opacity_scale"], "opacity_scale");
    if (opacity_scale < 0) throw Error("\"opacity_scale\": " + num(opacity_scale) + " (expected a number >= 0)");
  }

  std::vector<TransferPoint> pts;
  if (spec.contains("preset")) {
    const json& p = spec["preset"];
    if (!p.is_string()) throw Error("\"preset\": " + p.dump() + " (expected a preset name string)");
    const std::string name = p.get<std::string>();
    pts = preset_points(name);
    normalized = preset_is_normalized(name);
  } else if (spec.contains("points")) {
    const json& arr = spec["points"];
    if (!arr.is_array() || arr.empty()) throw Error("\"points\": " + arr.dump() + " (expected a non-empty array of points)");
    for (std::size_t i = 0; i < arr.size(); ++i) pts.push_back(parse_point(arr[i], "points[" + std::to_string(i) + "]"));
  } else {
    const json& f = spec["paraview"];
    if (!f.is_string()) throw Error("\"paraview\": " + f.dump() + " (expected a file name string)");
    std::string name;
    if (spec.contains("name")) {
      if (!spec["name"].is_string()) throw Error("\"name\": " + spec["name"].dump() + " (expected a string)");
      name = spec["name"].get<std::string>();
    }
    std::filesystem::path path(f.get<std::string>());
    if (path.is_relative() && !base_dir.empty()) path = std::filesystem::path(base_dir) / path;
    std::ifstream in(path);
    if (!in) throw Error("\"paraview\": \"" + path.string() + "\" cannot be opened (expected a ParaView colour map JSON file)");
    json exported;
    try {
      exported = json::parse(in);
    } catch (const json::exception& e) {
      throw Error("\"paraview\": \"" + path.string() + "\" is not valid JSON: " + e.what());
    }
    pts = with_context("\"paraview\": \"" + path.string() + "\"", [&] { return import_paraview_colormap(exported, name).points(); });
  }

  for (TransferPoint& p : pts) {
    if (normalized) p.value = data_min + p.value * (data_max - data_min);
    p.alpha = std::min(1.0f, p.alpha * opacity_scale);
  }
  return TransferFunction(std::move(pts));
}

TransferFunction import_paraview_colormap(const nlohmann::json& exported, const std::string& name) {
  const json* preset = nullptr;
  if (exported.is_object()) {
    preset = &exported;
    const json& n = exported.contains("Name") ? exported["Name"] : json();
    if (!name.empty() && !(n.is_string() && n == name))
      throw Error("ParaView colour map: no preset named \"" + name + "\" (the file has " + n.dump() + ")");
  } else if (exported.is_array()) {
    if (exported.empty()) throw Error("ParaView colour map: empty list (expected at least one preset)");
    std::string names;
    for (const json& p : exported) {
      if (!p.is_object()) throw Error("ParaView colour map: list entry " + p.dump() + " (expected an object)");
      const std::string n = p.contains("Name") && p["Name"].is_string() ? p["Name"].get<std::string>() : "";
      names += (names.empty() ? "" : ", ") + ("\"" + n + "\"");
      if (!preset && (name.empty() || n == name)) preset = &p;
    }
    if (!preset) throw Error("ParaView colour map: no preset named \"" + name + "\" (the file has " + names + ")");
  } else {
    throw Error("ParaView colour map: " + exported.dump() + " (expected a list of presets or one preset object)");
  }
  if (!preset->contains("RGBPoints")) throw Error("ParaView colour map: preset has no \"RGBPoints\"");
  // ColorSpace (Diverging, Lab, ...) is ignored: colours are interpolated linearly in RGB between nodes.
  // ParaView colours are display (sRGB) values; converted to linear RGB so they look the same on output.
  const Pwl<3> color = read_nodes<3>(*preset, "RGBPoints", 4);
  Pwl<1> opacity;
  if (preset->contains("Points")) {
    // Nodes are [x, opacity, midpoint, sharpness]; midpoint and sharpness (ParaView's curve shaping
    // between nodes) are ignored: opacity is interpolated linearly, which is their default 0.5 / 0.
    opacity = read_nodes<1>(*preset, "Points", 4);
  } else {
    // No opacity in the file: a linear ramp 0 -> 1 over the colour range, so low values are clear.
    opacity.xs = {color.xs.front(), color.xs.back()};
    opacity.ys = {{0.0f}, {1.0f}};
    if (opacity.xs[0] == opacity.xs[1]) opacity.ys[0] = {1.0f};
  }
  // Colour and opacity nodes may sit at different positions: evaluate both at the union of positions,
  // emitting two points where either function steps.
  std::vector<float> xs = color.xs;
  xs.insert(xs.end(), opacity.xs.begin(), opacity.xs.end());
  std::sort(xs.begin(), xs.end());
  xs.erase(std::unique(xs.begin(), xs.end()), xs.end());
  std::vector<TransferPoint> pts;
  for (const float x : xs) {
    for (const bool left : {true, false}) {
      const auto c = color.at(x, left);
      const float a = opacity.at(x, left)[0];
      TransferPoint p{x, Rgb(srgb_to_linear(c[0]), srgb_to_linear(c[1]), srgb_to_linear(c[2])), a};
      if (!left && pts.back().color == p.color && pts.back().alpha == p.alpha) continue;  // no step here
      pts.push_back(p);
    }
  }
  return TransferFunction(std::move(pts));
}

float opacity_correct(float alpha, float step_ratio) {
  if (!(alpha > 0.0f) || !(step_ratio > 0.0f)) return 0.0f;
  if (alpha >= 1.0f) return 1.0f;
  // 1 - (1 - a)^r through log1p/expm1: exact for the tiny alphas of thin media.
  const double r = -std::expm1(static_cast<double>(step_ratio) * std::log1p(-static_cast<double>(alpha)));
  return std::clamp(static_cast<float>(r), 0.0f, 1.0f);
}

float step_opacity(float alpha, float step_ratio, Compositing compositing) {
  if (compositing == Compositing::Alpha) return opacity_correct(alpha, step_ratio);
  if (!(alpha > 0.0f) || !(step_ratio > 0.0f)) return 0.0f;
  return std::clamp(static_cast<float>(-std::expm1(-static_cast<double>(alpha) * step_ratio)), 0.0f, 1.0f);
}

float extinction_coefficient(float alpha, Compositing compositing) {
  if (!(alpha > 0.0f)) return 0.0f;
  if (compositing == Compositing::Extinction) return alpha;
  return std::min(kMaxExtinction, static_cast<float>(-std::log1p(-std::min(static_cast<double>(alpha), 1.0))));
}

TransferLut::TransferLut(const TransferFunction& tf, float lo, float hi, float step_ratio, int size,
                         Compositing compositing) {
  if (size < 2) throw Error("transfer function table size " + std::to_string(size) + " (expected at least 2)");
  if (!std::isfinite(lo) || !std::isfinite(hi)) throw Error("transfer function table range is not finite");
  if (!(hi > lo)) hi = lo + 1.0f;
  lo_ = lo;
  hi_ = hi;
  size_ = size;
  max_index_ = static_cast<float>(size - 1);
  scale_ = max_index_ / (hi - lo);
  table_.resize(static_cast<std::size_t>(size));
  visible_prefix_.assign(static_cast<std::size_t>(size) + 1, 0);
  for (int i = 0; i < size; ++i) {
    const double v = static_cast<double>(lo) + (static_cast<double>(hi) - lo) * i / (size - 1);
    Rgba e = tf.evaluate(static_cast<float>(v));
    e.a = step_opacity(e.a, step_ratio, compositing);
    const std::size_t k = static_cast<std::size_t>(i);
    table_[k] = e;
    visible_prefix_[k + 1] = visible_prefix_[k] + (e.a > 0.0f ? 1 : 0);
  }
}

int TransferLut::index_of(float value) const {
  float f = (value - lo_) * scale_;
  f = std::isnan(f) ? 0.0f : std::clamp(f, 0.0f, max_index_);
  return static_cast<int>(std::floor(f));
}

bool TransferLut::any_visible(float a, float b) const {
  if (size_ == 0) return false;
  if (a > b) std::swap(a, b);
  const int first = index_of(a);
  // b rounds up: a linear fetch just below entry j also reads entry j.
  float fb = (b - lo_) * scale_;
  fb = std::isnan(fb) ? max_index_ : std::clamp(fb, 0.0f, max_index_);
  const int last = static_cast<int>(std::ceil(fb));
  return visible_prefix_[static_cast<std::size_t>(last) + 1] - visible_prefix_[static_cast<std::size_t>(first)] > 0;
}

}  // namespace penumbra
