// The baseline paper 002 argues against: extract the whole isosurface as triangles (Lorensen & Cline,
// "Marching cubes", SIGGRAPH 1987), then rasterise them for every view. marching_cubes visits every
// cell of every brick whose range may hold the isovalue (GridTree), places the vertices by linear
// interpolation along the cell edges and gives each the normalized gradient; rasterize_mesh is a
// software z-buffer whose pixel centres and rays are those of PrimaryRays, so its points compare
// pixel for pixel with the ray-cast reference (isosurface_raycaster.h).
#pragma once

#include <cstddef>
#include <vector>

#include "penumbra/core/clip_planes.h"
#include "penumbra/core/math.h"
#include "penumbra/geometry/grid_tree.h"
#include "penumbra/geometry/iso_point.h"
#include "penumbra/scene/camera.h"

namespace penumbra {

struct TriangleMesh {
  std::vector<Vec3> vertices;  // three per triangle
  std::vector<Vec3> normals;   // per vertex: the normalized gradient (zero where the gradient vanishes)

  std::size_t triangles() const { return vertices.size() / 3; }
  std::size_t memory_bytes() const { return (vertices.capacity() + normals.capacity()) * sizeof(Vec3); }
};

// The isosurface of the tree's volume at `isovalue`, inside being value >= isovalue (iso_point.h).
// Triangles are ordered by brick slab (z), brick (y, x) and cell (z, y, x): the same for any thread
// count. Vertices shared by neighbouring cells are bit-identical, so the mesh is watertight away from
// the volume's border.
TriangleMesh marching_cubes(const GridTree& tree, float isovalue);

// One point per pixel whose centre a triangle covers, in pixel order (y, then x): the nearest
// triangle's point at that pixel (perspective-correct barycentric interpolation), its interpolated
// normal normalized and turned to face the eye, and its distance from the eye. Triangles are clipped
// to the near plane and to a guard band, and filled by the top-left rule on 1/256-pixel fixed-point
// vertices, so a pixel on an edge two triangles share is covered once. The same for any thread count.
// `clip`: planes that cut the surface (its fragments beyond them are not drawn).
IsoPoints rasterize_mesh(const TriangleMesh& mesh, const Camera& camera, const ClipPlanes& clip = ClipPlanes());

}  // namespace penumbra
