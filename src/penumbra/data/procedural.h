// Procedural volumes for the demo and the tests (no files needed). Each fills a cube of `size`^3 voxels
// spanning the world box [-0.5, 0.5]^3 (spacing 1/(size-1), origin -0.5), except "ct-body", a whole-body
// CT in millimetres on a grid of its own (ct_body.h).
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <string>
#include <vector>

#include "penumbra/data/volume.h"

namespace penumbra {

// Names: "test-spheres" (float32 density in [0, 1]: overlapping spheres of different densities that the
// "test-spheres" transfer function preset colours differently), "slab" (a homogeneous slab, density 1,
// between |y| <= thickness/2), "sphere" (a homogeneous ball of density 1), "hollow-sphere" (a shell),
// "marschner-lobb" (the classic 1994 test signal), "ct-body" (uint16 CT of a Visible-Woman-sized body).
std::vector<std::string> procedural_volume_names();

// Builds from the scene-file object {"name": "...", "size": N, ...parameters}; unknown keys are errors.
// Parameters: size (default 64, 2..1024); slab: thickness (0.3); sphere: radius (0.35);
// hollow-sphere: radius (0.35), thickness (0.08); test-spheres: seed (none: a fixed layout);
// marschner-lobb: alpha (0.25), fm (6). Density outside the shapes is 0.
// ct-body takes no size: dims ([512, 512, 1734], each 8..2048), seed (1), noise (60, at most 10000).
Volume make_procedural_volume(const nlohmann::json& spec);

}  // namespace penumbra
