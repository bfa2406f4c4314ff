// The eye pass of an isosurface (paper 002): its visible surface points — by view-dependent point
// extraction (`points`), by ray casting (`raycast`, the exact reference) or by rasterising the
// marching-cubes mesh (`mesh`, the baseline). The frame (surface_frame.h) then takes per pixel the
// nearest of these points, the spheres and the planes, and shades them.
#pragma once

#include <memory>
#include <span>
#include <vector>

#include "penumbra/core/image.h"
#include "penumbra/geometry/grid_tree.h"
#include "penumbra/geometry/isosurface_raycaster.h"
#include "penumbra/isosurface/marching_cubes.h"
#include "penumbra/isosurface/point_extraction.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

// What an isosurface keeps between frames: the min/max hierarchy (built once per volume, valid for
// every isovalue), and for the other methods the ray caster or the mesh.
struct PreparedIsosurface {
  // `tree` is the hierarchy of the object's volume (shared by the isosurfaces of one volume).
  PreparedIsosurface(std::shared_ptr<const GridTree> tree, const IsosurfaceObject& object);

  const IsosurfaceObject* object;
  std::shared_ptr<const GridTree> tree;
  IsosurfaceRaycaster raycaster;        // the reference eye pass and exact shadow rays
  std::unique_ptr<TriangleMesh> mesh;   // `mesh`: extracted on the first frame
};

struct IsosurfaceFrameStats {
  double extract_ms = 0;  // eye pass: point extraction, ray casting or mesh rasterisation
  double mesh_ms = 0;     // marching cubes, on the frame that extracted the mesh
  double shadow_ms = 0;   // the lights' shadow passes
  double shade_ms = 0;
  std::size_t points = 0;        // isosurface points of the eye pass (one per covered pixel)
  std::size_t light_points = 0;  // light_pass: points extracted from the lights
  std::size_t holes = 0;         // light_pass: light pixels punched by the receivers (§4.2)
  std::size_t triangles = 0;     // mesh
  ExtractionStats extraction;    // points: the eye pass's traversal

  void add(const IsosurfaceFrameStats& o) {  // the times and counts of another isosurface's eye pass
    extract_ms += o.extract_ms;
    mesh_ms += o.mesh_ms;
    triangles += o.triangles;
    extraction.add(o.extraction);
  }
};

// The eye pass alone: the isosurface's visible points for `camera` by the object's method; `clip`: the
// planes that cut it (what they remove is not drawn, and the surface behind shows). `finer`: the same
// surface over a box of finer voxels (a full frame of a volume opened coarse, render/view_refinement.h),
// drawn inside the box's bounds and `iso` around it — `points` extracts from both, the box kept out of
// iso's pass (ExtractionOptions::exclude), and the frame keeps each pixel's nearer point; `raycast` meets
// the box's surface inside it (IsosurfaceRaycaster::render). `mesh` takes none (not refined).
IsoPoints isosurface_eye_points(const Camera& camera, PreparedIsosurface& iso, IsosurfaceFrameStats& stats,
                                const ClipPlanes& clip = ClipPlanes(), const PreparedIsosurface* finer = nullptr);

}  // namespace penumbra
