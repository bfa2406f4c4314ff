// What every isosurface method hands to shading: one point per covered pixel, with its world position,
// unit normal (the field's gradient, turned to face the viewer) and the pixel it covers. The
// view-dependent extraction (paper 002 §3), the ray-cast reference and the rasterised mesh all produce
// this list, so shading and shadows treat the three alike.
#pragma once

#include <algorithm>
#include <cstdint>
#include <vector>

#include "penumbra/core/math.h"

namespace penumbra {

// Inside/outside convention of every isosurface method: a value v is inside when v >= isovalue. A cell
// (2x2x2 voxels) holds the surface when its corners' min < isovalue <= max.
inline bool range_straddles(float lo, float hi, float isovalue) { return lo < isovalue && isovalue <= hi; }

struct IsoPoint {
  Vec3 position;
  Vec3 normal;          // unit
  float distance;       // from the viewpoint it was extracted for (eye or light)
  std::uint32_t pixel;  // y * width + x in that view's image
  float error = 0;      // how far from the surface it may lie: 0 for exact roots, up to a cell for cell points
};

using IsoPoints = std::vector<IsoPoint>;

// The points of a per-pixel buffer (a ray cast, a rasterised mesh), in pixel order: at_pixel[i] for
// every pixel i that is covered.
inline IsoPoints points_in_pixel_order(const std::vector<IsoPoint>& at_pixel, const std::vector<std::uint8_t>& covered) {
  IsoPoints points;
  points.reserve(static_cast<std::size_t>(std::count(covered.begin(), covered.end(), std::uint8_t{1})));
  for (std::size_t i = 0; i < at_pixel.size(); ++i)
    if (covered[i]) points.push_back(at_pixel[i]);
  return points;
}

}  // namespace penumbra
