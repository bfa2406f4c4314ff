// View-dependent point-based isosurface extraction (PIsA, as described in paper 002 §3): a front-to-back
// traversal of the GridTree relative to the viewpoint with value-based pruning (§3.1.1: a node whose
// min/max range cannot hold the isovalue is skipped) and visibility-based pruning (§3.1.2: a node whose
// projected bounding box covers no pixel still marked visible in the 1-bit VisibilityBuffer is hidden
// by points already extracted and is skipped). At the leaves, cells holding the surface give points at
// pixel resolution (§3.2) that mark their pixels covered: a cell smaller than a pixel gives one point
// (the mean of its edge crossings, on the surface to within the cell), a larger cell one point per
// visible pixel it covers (the root of the trilinear interpolant along that pixel's ray). A node that
// projects into a single pixel may collapse into one point for the whole sub-volume (§4.3, the
// "far-subvolume" point; the shadow pass turns it off).
//
// Parallelism: the image is cut into tiles, and each tile runs the whole traversal with its own
// visibility buffer, clipped to its pixels; the points come out in tile order, so the result is the
// same for any number of threads.
#pragma once

#include <cstddef>

#include "penumbra/core/clip_planes.h"
#include "penumbra/geometry/grid_tree.h"
#include "penumbra/geometry/iso_point.h"
#include "penumbra/isosurface/view_projection.h"
#include "penumbra/isosurface/visibility_buffer.h"

namespace penumbra {

struct ExtractionOptions {
  bool collapse = true;    // far-subvolume collapse: a node that projects into one pixel becomes one point
  bool normals = true;     // gradient normals (the light pass needs only positions and distances)
  bool visibility_pruning = true;  // off: every node that holds the surface is visited (tests, figures)
  // The pass starts from this buffer (the light pass's punched holes, §4.2) instead of all pixels
  // visible; same size as the view.
  const VisibilityBuffer* start = nullptr;
  // Clip planes that cut the surface (core/clip_planes.h): points they remove are not emitted, so the
  // pixel stays open for the kept surface behind them.
  const ClipPlanes* clip = nullptr;
  // A box whose surface another pass draws (a refined box of a finer level, render/view_refinement.h):
  // no point inside it is emitted (nodes inside it are skipped), and a pixel's ray through a larger cell
  // looks for the surface before the box and behind it, so the two passes meet at the box's faces.
  const Box3* exclude = nullptr;
  int tile = 64;           // tile side in pixels
};

struct ExtractionStats {
  std::size_t nodes_visited = 0;       // GridTree nodes and in-brick blocks reached
  std::size_t value_pruned = 0;        // ... skipped by their min/max range
  std::size_t visibility_pruned = 0;   // ... skipped because no pixel under them was still visible
  std::size_t cells_visited = 0;       // cells holding the surface whose pixels were tested
  std::size_t collapsed = 0;           // far-subvolume points
  double ms = 0;

  void add(const ExtractionStats& o) {
    nodes_visited += o.nodes_visited;
    value_pruned += o.value_pruned;
    visibility_pruned += o.visibility_pruned;
    cells_visited += o.cells_visited;
    collapsed += o.collapsed;
  }
};

struct Extraction {
  IsoPoints points;  // at most one per pixel; normals face the viewpoint
  ExtractionStats stats;
};

Extraction extract_points(const GridTree& tree, float isovalue, const ViewProjection& view,
                          const ExtractionOptions& options = {});

}  // namespace penumbra
