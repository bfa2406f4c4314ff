#include "penumbra/render/isosurface_frame.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "penumbra/core/error.h"
#include "penumbra/core/timer.h"

namespace penumbra {

PreparedIsosurface::PreparedIsosurface(std::shared_ptr<const GridTree> t, const IsosurfaceObject& o)
    : object(&o), tree(std::move(t)), raycaster(*tree, o.value) {}

IsoPoints isosurface_eye_points(const Camera& camera, PreparedIsosurface& iso, IsosurfaceFrameStats& stats,
                                const ClipPlanes& clip, const PreparedIsosurface* finer) {
  const IsosurfaceObject& o = *iso.object;
  switch (o.method) {
    case IsosurfaceMethod::Points: {
      ExtractionOptions options;
      options.collapse = o.collapse;
      options.clip = clip.empty() ? nullptr : &clip;
      const Box3 box = finer ? finer->tree->volume().bounds() : Box3{};
      options.exclude = finer ? &box : nullptr;
      Extraction e = extract_points(*iso.tree, o.value, ViewProjection::from_camera(camera), options);
      stats.extract_ms = e.stats.ms;
      stats.extraction = e.stats;
      if (finer) {
        options.exclude = nullptr;
        Extraction f = extract_points(*finer->tree, o.value, ViewProjection::from_camera(camera), options);
        stats.extract_ms += f.stats.ms;
        stats.extraction.add(f.stats);
        e.points.insert(e.points.end(), f.points.begin(), f.points.end());
      }
      return std::move(e.points);
    }
    case IsosurfaceMethod::Raycast: {
      Timer t;
      IsoPoints points = iso.raycaster.render(camera, clip, finer ? &finer->raycaster : nullptr);
      stats.extract_ms = t.elapsed_ms();
      return points;
    }
    case IsosurfaceMethod::Mesh: {
      if (finer) throw Error("internal: a mesh isosurface is not refined");
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
