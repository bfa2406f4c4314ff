// The Renderer's share of a data-parallel frame (DESIGN.md "Built to scale", docs/distributed.md):
// which receivers a brick's view-dependent light structures fit, and the opaque surfaces a brick does
// not show.
#include <algorithm>
#include <cmath>

#include "penumbra/core/parallel.h"
#include "penumbra/render/renderer.h"

namespace penumbra {

std::vector<SurfacePoint> Renderer::receivers_shown(const ShadowBrick& brick, const Camera& camera, const VisibleSurfaces& surfaces) const {
  // the rectangle holding every brick's surface pixels (a minimum of {x0, y0, −x1, −y1}: integers, exact
  // in floats), then the minimum distance over the bricks on that rectangle only
  const auto column = [&](std::uint32_t p) { return static_cast<int>(p % static_cast<std::uint32_t>(camera.width)); };
  const auto row = [&](std::uint32_t p) { return static_cast<int>(p / static_cast<std::uint32_t>(camera.width)); };
  float bounds[] = {static_cast<float>(camera.width), static_cast<float>(camera.height), 0, 0};
  for (const std::uint32_t p : surfaces.pixel) {
    bounds[0] = std::min(bounds[0], static_cast<float>(column(p))), bounds[1] = std::min(bounds[1], static_cast<float>(row(p)));
    bounds[2] = std::min(bounds[2], -static_cast<float>(column(p) + 1)), bounds[3] = std::min(bounds[3], -static_cast<float>(row(p) + 1));
  }
  brick.reduction->minimum(bounds);
  const int x0 = static_cast<int>(bounds[0]), y0 = static_cast<int>(bounds[1]);
  const int columns = std::max(0, static_cast<int>(-bounds[2]) - x0), rows = std::max(0, static_cast<int>(-bounds[3]) - y0);
  std::vector<float> nearest(static_cast<std::size_t>(columns) * static_cast<std::size_t>(rows));
  for (int y = 0; y < rows; ++y)
    for (int x = 0; x < columns; ++x)
      nearest[static_cast<std::size_t>(y) * static_cast<std::size_t>(columns) + static_cast<std::size_t>(x)] =
          surfaces.distance[static_cast<std::size_t>(y0 + y) * static_cast<std::size_t>(camera.width) + static_cast<std::size_t>(x0 + x)];
  brick.reduction->minimum(nearest);
  const PrimaryRays rays(camera);
  std::vector<SurfacePoint> shown;
  for (std::size_t i = 0; i < surfaces.points.size(); ++i) {
    // the brick whose slab holds the nearest point passes its own nearest point, which is that one (two
    // bricks holding the same cell may place its point a rounding apart)
    const int x = column(surfaces.pixel[i]), y = row(surfaces.pixel[i]);
    const float d = nearest[static_cast<std::size_t>(y - y0) * static_cast<std::size_t>(columns) + static_cast<std::size_t>(x - x0)];
    if (brick.slab.owns(rays.ray(x, y).at(d))) shown.push_back(surfaces.points[i]);
  }
  return shown;
}

void Renderer::drop_surfaces_outside(const SampleSlab& slab, const Camera& camera, std::span<const float> distance, Image& opaque,
                                     std::span<float> alpha) const {
  const PrimaryRays rays(camera);
  parallel_for(static_cast<std::size_t>(camera.height), [&](std::size_t y0, std::size_t y1) {
    for (std::size_t y = y0; y < y1; ++y)
      for (int x = 0; x < camera.width; ++x) {
        const std::size_t p = y * static_cast<std::size_t>(camera.width) + static_cast<std::size_t>(x);
        if (!std::isfinite(distance[p]) || slab.owns(rays.ray(x, static_cast<int>(y)).at(distance[p]))) continue;
        opaque.at(x, static_cast<int>(y)) = scene_.background;
        alpha[p] = 0;
      }
  });
}

}  // namespace penumbra
