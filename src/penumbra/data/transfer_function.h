// Transfer functions: scalar value -> (colour, opacity). Piecewise linear between control points in the
// volume's data units (Hounsfield units for CT), resolved once into a lookup table for the hot loop.
//
// Opacity convention: a control point's alpha is the opacity of one *reference step* of length
// `reference_step` (world units; the renderer uses the volume's smallest voxel spacing). A sample taken
// with step Δs uses the corrected opacity α' = 1 − (1 − α)^(Δs / reference_step) (opacity_correct()).
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <string>
#include <vector>

#include "penumbra/core/color.h"

namespace penumbra {

struct TransferPoint {
  float value = 0;  // data units
  Rgb color;        // linear RGB in [0, 1]
  float alpha = 0;  // opacity per reference step, in [0, 1]
  bool operator==(const TransferPoint&) const = default;
};

class TransferFunction {
public:
  TransferFunction() = default;
  // Points need not be sorted; they are sorted by value. Throws Error on NaN, colour or alpha outside
  // [0, 1], or an empty list.
  explicit TransferFunction(std::vector<TransferPoint> points);

  // Piecewise-linear evaluation; constant beyond the first and last point.
  Rgba evaluate(float value) const;
  const std::vector<TransferPoint>& points() const { return points_; }
  bool operator==(const TransferFunction&) const = default;

private:
  std::vector<TransferPoint> points_;
};

// Names of the built-in presets: "ct-bone", "ct-soft-tissue" (Hounsfield units), "mri-head"
// (normalised to the data range), "test-spheres" (for the procedural test-spheres volume), "grayscale",
// and matplotlib's colour maps by name (colormaps.h: viridis, magma, ..., over the normalised range).
std::vector<std::string> transfer_function_preset_names();

// Builds a transfer function from its scene-file JSON (docs/scene-file.md), e.g.
//   {"preset": "ct-bone"}
//   {"points": [[value, r, g, b, alpha], ...], "domain": "data" | "normalized"}
//   {"paraview": "colormap.json", "name": "optional preset name in the file"}
// plus the optional "opacity_scale" (multiplies every alpha). "normalized" values map [0, 1] onto
// [data_min, data_max]. Relative paths are resolved against base_dir. Unknown keys are errors.
TransferFunction parse_transfer_function(const nlohmann::json& spec, float data_min, float data_max,
                                         const std::string& base_dir);

// Reads a ParaView colour-map JSON export (a list of presets with "RGBPoints" and optional "Points"
// for opacity; the first preset, or the one called `name`). Without "Points", opacity is a linear ramp.
TransferFunction import_paraview_colormap(const nlohmann::json& exported, const std::string& name);

// Opacity correction for a step of `step_ratio` reference steps.
float opacity_correct(float alpha, float step_ratio);

// How a volume's transfer-function opacity is read (DESIGN.md `volumes[].compositing`):
// Alpha: the opacity of one reference step (opacity_correct() for other steps);
// Extinction: the extinction coefficient τ in units of 1 / reference step (paper 001, Eq. 2), so a step of
// `step_ratio` reference steps has opacity 1 − exp(−α·step_ratio).
enum class Compositing { Alpha, Extinction };

// Opacity of a step of `step_ratio` reference steps under either reading.
float step_opacity(float alpha, float step_ratio, Compositing compositing);

// Extinction coefficient τ (per reference step) of a transfer-function opacity: α itself under
// Extinction; −ln(1 − α) under Alpha (the τ that gives opacity α over one reference step; α = 1 is
// capped at kMaxExtinction).
constexpr float kMaxExtinction = 16.0f;
float extinction_coefficient(float alpha, Compositing compositing);

// The transfer function tabulated over [lo, hi] with `size` entries, opacity already corrected for one
// sampling step. lookup() is a clamped linear fetch. any_visible(a, b) says whether any value in [a, b]
// has non-zero opacity: O(1) through a prefix count, used for empty-space skipping.
class TransferLut {
public:
  TransferLut() = default;
  TransferLut(const TransferFunction& tf, float lo, float hi, float step_ratio, int size = 4096,
              Compositing compositing = Compositing::Alpha);
  [[gnu::always_inline]] Rgba lookup(float value) const {  // (inlined: once per volume sample)
    float f = (value - lo_) * scale_;
    f = f < 0 ? 0 : (f > max_index_ ? max_index_ : f);
    const int i = static_cast<int>(f);
    const int j = i + 1 < size_ ? i + 1 : i;
    const float t = f - static_cast<float>(i);
    const Rgba& a = table_[static_cast<std::size_t>(i)];
    const Rgba& b = table_[static_cast<std::size_t>(j)];
    return {a.rgb + (b.rgb - a.rgb) * t, a.a + (b.a - a.a) * t};
  }
  bool any_visible(float a, float b) const;
  float lo() const { return lo_; }
  float hi() const { return hi_; }
  int size() const { return size_; }

private:
  int index_of(float value) const;
  std::vector<Rgba> table_;
  std::vector<int> visible_prefix_;  // visible_prefix_[i] = number of entries < i with alpha > 0
  float lo_ = 0, hi_ = 1, scale_ = 1, max_index_ = 0;
  int size_ = 0;
};

}  // namespace penumbra
