#include "penumbra/render/isosurface_buffers.h"

#include <algorithm>

namespace penumbra {

Image visibility_image(const VisibilityBuffer& buffer) {
  Image image(buffer.width(), buffer.height(), Rgb(0.0f));
  for (int y = 0; y < buffer.height(); ++y)
    for (int x = 0; x < buffer.width(); ++x)
      if (buffer.visible(x, y)) image.at(x, y) = Rgb(1.0f);
  return image;
}

Image coverage_image(const IsoPoints& points, int width, int height) {
  Image image(width, height, Rgb(1.0f));
  for (const IsoPoint& p : points)
    image.at(static_cast<int>(p.pixel % static_cast<std::uint32_t>(width)), static_cast<int>(p.pixel / static_cast<std::uint32_t>(width))) = Rgb(0.0f);
  return image;
}

Image distance_image(const IsoPoints& points, int width, int height) {
  Image image(width, height, Rgb(0.0f));
  float lo = kInfinity, hi = -kInfinity;
  for (const IsoPoint& p : points) {
    lo = std::min(lo, p.distance);
    hi = std::max(hi, p.distance);
  }
  const float range = hi > lo ? hi - lo : 1.0f;
  for (const IsoPoint& p : points)
    image.at(static_cast<int>(p.pixel % static_cast<std::uint32_t>(width)), static_cast<int>(p.pixel / static_cast<std::uint32_t>(width))) =
        Rgb(1.0f - 0.8f * (p.distance - lo) / range);
  return image;
}

}  // namespace penumbra
