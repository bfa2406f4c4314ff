// Matplotlib's colour maps by name, as sRGB samples over [0, 1] (colormaps.cpp lists them).
#pragma once

#include <array>
#include <string>
#include <vector>

namespace penumbra {

constexpr std::size_t kColormapSamples = 33;
using ColormapSamples = std::array<std::array<float, 3>, kColormapSamples>;  // sRGB, evenly spaced over [0, 1]

// The samples of a colour map named as matplotlib names it (case-insensitive; "grey" is "gray"), or null.
const ColormapSamples* colormap_samples(const std::string& name);
std::vector<std::string> colormap_names();

}  // namespace penumbra
