// A periodic box for distance selections: the cell vectors of MDAnalysis's `dimensions` (a along x,
// b in the xy plane, as MDAnalysis.lib.mdamath.triclinic_vectors), fractional coordinates, and the
// perpendicular widths that size a neighbour grid.
#pragma once

#include <optional>

#include "penumbra/core/math.h"
#include "penumbra/data/selection/atom_topology.h"

namespace penumbra {

struct PeriodicCell {
  Vec3 a, b, c;                 // cell vectors (Å)
  Vec3 inverse_rows[3];         // rows of the inverse of [a b c]: fractional coordinate i = dot(row i, p)
  float width[3];               // distance between opposite faces (Å)

  Vec3 fractional(Vec3 p) const { return {dot(inverse_rows[0], p), dot(inverse_rows[1], p), dot(inverse_rows[2], p)}; }
  Vec3 cartesian(Vec3 f) const { return a * f.x + b * f.y + c * f.z; }
  // Squared length of the shortest periodic image of d.
  float minimum_image_length2(Vec3 d) const;
};

// The cell of `dimensions`, or none when there are none or they do not describe a box (a zero
// length, as MDAnalysis treats such dimensions).
std::optional<PeriodicCell> periodic_cell(const std::optional<CellDimensions>& dimensions);

}  // namespace penumbra
