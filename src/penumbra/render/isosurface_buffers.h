// Pictures of the point-based isosurface's buffers, for `penumbra render --buffers` and the docs (paper
// 002, Figs. 2 and 6): a 1-bit buffer as black (non-visible) and white (visible) pixels, and the
// points of a pass coloured by distance (near bright, far dark) over black.
#pragma once

#include "penumbra/core/image.h"
#include "penumbra/geometry/iso_point.h"
#include "penumbra/isosurface/visibility_buffer.h"

namespace penumbra {

// White where visible, black where not.
Image visibility_image(const VisibilityBuffer& buffer);
// The final visibility mask of a pass: the pixels its points covered are non-visible (black), the rest
// still visible (white) — the paper's Fig. 2 right.
Image coverage_image(const IsoPoints& points, int width, int height);
// The points' distances, near white to far dark grey; empty pixels black.
Image distance_image(const IsoPoints& points, int width, int height);

}  // namespace penumbra
