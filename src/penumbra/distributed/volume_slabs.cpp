#include "penumbra/distributed/volume_slabs.h"

#include <string>
#include <utility>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/render/renderer.h"

namespace penumbra {

std::vector<SampleSlab> volume_slabs(const Volume& volume, int count) {
  const int nz = volume.whole_dims()[2];  // a window (one rank's brick) is cut from the whole grid
  if (count < 1 || count > nz)
    throw Error(std::to_string(count) + " slabs for a volume of " + std::to_string(nz) + " voxel slices along z (expected 1 to " +
                std::to_string(nz) + ")");
  const Box3 box = volume.bounds();  // through the first and last voxel centres
  const float spacing = nz > 1 ? (box.hi.z - box.lo.z) / static_cast<float>(nz - 1) : 0.0f;
  std::vector<SampleSlab> slabs(static_cast<std::size_t>(count));
  for (int b = 1; b < count; ++b) {  // between slice first − 1 and first
    const int first = static_cast<int>(static_cast<long long>(nz) * b / count);
    const float z = box.lo.z + (static_cast<float>(first) - 0.5f) * spacing;
    slabs[static_cast<std::size_t>(b - 1)].z_hi = z;
    slabs[static_cast<std::size_t>(b)].z_lo = z;
  }
  return slabs;
}

Image composite_slabs(std::span<const BrickImage> bricks, const Camera& camera, const Rgb& background) {
  Image out(camera.width, camera.height);
  const PrimaryRays rays(camera);
  const std::size_t n = bricks.size();
  parallel_for(static_cast<std::size_t>(camera.height), [&](std::size_t y0, std::size_t y1) {
    for (int y = static_cast<int>(y0); y < static_cast<int>(y1); ++y)
      for (int x = 0; x < camera.width; ++x) {
        const std::size_t pixel = static_cast<std::size_t>(y) * static_cast<std::size_t>(camera.width) + static_cast<std::size_t>(x);
        out.at(x, y) = composite_pixel(n, rays.direction(x, y).z < 0, background, [&](std::size_t b) {
          return std::pair<Rgb, float>(bricks[b].color->at(x, y), bricks[b].opacity[pixel]);
        });
      }
  });
  return out;
}

void check_has_volume(const Scene& scene) {
  if (scene.volumes.empty())
    throw Error("the scene must hold a volume, whose slabs split the frame (spheres, isosurfaces and planes alone are not split)");
}

SlabFrame render_in_slabs(const Scene& scene, int count) {
  check_has_volume(scene);
  SlabFrame out;
  out.slabs = volume_slabs(*scene.volumes.front().volume, count);
  Scene over_black = scene;
  over_black.background = Rgb(0.0f);
  Renderer renderer(over_black);
  std::vector<FrameResult> frames;
  for (const SampleSlab& slab : out.slabs) {
    FrameRequest request;
    request.slab = slab;
    frames.push_back(renderer.render(request));
    out.render_ms.push_back(frames.back().render_ms);
  }
  std::vector<BrickImage> bricks;
  for (const FrameResult& f : frames) bricks.push_back({&f.image, f.alpha});
  Timer composite;
  out.image = composite_slabs(bricks, scene.camera, scene.background);
  out.composite_ms = composite.elapsed_ms();
  return out;
}

}  // namespace penumbra
