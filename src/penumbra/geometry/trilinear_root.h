// The exact intersection of a ray with the isosurface inside one cell: along a ray the trilinear
// interpolant of a cell is a cubic in the ray parameter, whose first root is found as in Marmitt,
// Kleer, Wald, Friedrich and Slusallek, "Fast and accurate ray-voxel intersection techniques for
// iso-surface ray tracing" (VMV 2004, §3): the cubic's coefficients from the eight corners, the
// segment split at the roots of its derivative into monotone pieces, and the first piece whose ends
// differ in sign refined to float precision. Paper 002 (Livnat & Tricoche) measures its points
// against this, "the root of the trilinear interpolant along each ray" (Parker et al. 1998).
//
// Inside convention (iso_point.h): a point is inside when f >= isovalue. A crossing is any change of
// that state along the ray, outside to inside or inside to outside; the crossing returned is the
// first parameter at which the state differs from the state at the segment's start, so a ray that
// starts exactly on the surface (f == isovalue: inside) reports where it leaves, not its start.
#pragma once

#include <array>

#include "penumbra/core/math.h"
#include "penumbra/data/volume.h"

namespace penumbra {

// The values of a cell's eight voxels: corners[n] is voxel (i + (n & 1), j + ((n >> 1) & 1), k + (n >> 2)).
using CornerValues = std::array<float, 8>;

// A ray in the volume's continuous voxel coordinates (voxel (i, j, k) at (i, j, k)), in double
// precision, so that a cell far from the origin keeps the ray's position to well below a voxel.
struct GridRay {
  std::array<double, 3> origin;
  std::array<double, 3> direction;  // voxels per unit of the world ray's t
  GridRay(const Volume& volume, const Ray& ray);
};

// The smallest t in [t0, t1] at which the inside state of the cell's trilinear interpolant along the
// ray differs from the state at t0, or kInfinity. [t0, t1] is normally the ray's segment inside the
// cell (Box3::clip of GridTree::cell_box); beyond the cell the same cubic is continued.
float first_crossing_in_cell(const Volume& volume, const std::array<int, 3>& cell, float isovalue, const Ray& ray,
                             float t0, float t1);

// The same on corners already fetched, with the state before t0 given by the caller (the state where
// the ray left the previous cell): returns t0 when the state at t0 already differs from `inside_before`,
// so that a crossing lying exactly on the face between two cells is not lost to rounding.
float first_state_change(const CornerValues& corners, const std::array<int, 3>& cell, float isovalue,
                         const GridRay& ray, float t0, float t1, bool inside_before);

// Whether the cell's trilinear interpolant is inside at t (the state first_crossing_in_cell starts from).
bool inside_at(const CornerValues& corners, const std::array<int, 3>& cell, float isovalue, const GridRay& ray, float t);

}  // namespace penumbra
