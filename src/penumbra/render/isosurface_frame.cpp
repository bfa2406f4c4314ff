#include "penumbra/render/isosurface_frame.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "penumbra/core/timer.h"

namespace penumbra {

PreparedIsosurface::PreparedIsosurface(std::shared_ptr<const GridTree> t, const IsosurfaceObject& o)
    : object(&o), tree(std::move(t)), raycaster(*tree, o.value) {}

IsoPoints isosurface_eye_points(const Camera& camera, PreparedIsosurface& iso, IsosurfaceFrameStats& stats,
                                const ClipPlanes& clip, const Box3* exclude) {
  const IsosurfaceObject& o = *iso.object;
  switch (o.method) {
    case IsosurfaceMethod::Points: {
      ExtractionOptions options;
      options.collapse = o.collapse;
      options.clip = clip.empty() ? nullptr : &clip;
      options.exclude = exclude;
      Extraction e = extract_points(*iso.tree, o.value, ViewProjection::from_camera(camera), options);
      stats.extract_ms = e.stats.ms;
      stats.extraction = e.stats;
      return std::move(e.points);
    }
    case IsosurfaceMethod::Raycast: {
      Timer t;
      IsoPoints points = iso.raycaster.render(camera, clip);
      stats.extract_ms = t.elapsed_ms();
      return points;
    }
    case IsosurfaceMethod::Mesh: {
      if (!iso.mesh) {
        Timer t;
        iso.mesh = std::make_unique<TriangleMesh>(marching_cubes(*iso.tree, o.value));
        stats.mesh_ms = t.elapsed_ms();
      }
      stats.triangles = iso.mesh->triangles();
      Timer t;
      IsoPoints points = rasterize_mesh(*iso.mesh, camera, clip);
      stats.extract_ms = t.elapsed_ms();
      return points;
    }
  }
  return {};
}

}  // namespace penumbra
