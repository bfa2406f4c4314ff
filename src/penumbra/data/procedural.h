// Procedural volumes for the demo and the tests (no files needed). Each fills a cube of `size`^3 voxels
// spanning the world box [-0.5, 0.5]^3 (spacing 1/(size-1), origin -0.5), except "ct-body", a whole-body
// CT in millimetres on a grid of its own (ct_body.h), and "molecular-density", a grid in the ångström of a
// molecule file.
#pragma once

#include <nlohmann/json_fwd.hpp>

#include <string>
#include <vector>

#include "penumbra/data/ct_body.h"
#include "penumbra/data/volume.h"

namespace penumbra {

// Names: "test-spheres" (float32 density in [0, 1]: overlapping spheres of different densities that the
// "test-spheres" transfer function preset colours differently), "slab" (a homogeneous slab, density 1,
// between |y| <= thickness/2), "sphere" (a homogeneous ball of density 1), "hollow-sphere" (a shell),
// "marschner-lobb" (the classic 1994 test signal), "ct-body" (uint16 CT of a Visible-Woman-sized body),
// "molecular-density" (float32 Gaussian splat of a molecule's atoms, what cryo-EM maps look like).
std::vector<std::string> procedural_volume_names();

// Builds from the scene-file object {"name": "...", "size": N, ...parameters}; unknown keys are errors.
// Parameters: size (default 64, 2..1024); slab: thickness (0.3); sphere: radius (0.35), and for a time
// series frames (0: none; N: one turn of the ball around the y axis over N frames), frame (the one to
// make; the scene reader sets it from the scene's `time`), orbit (0.25, the turn's radius);
// hollow-sphere: radius (0.35), thickness (0.08); test-spheres: seed (none: a fixed layout);
// marschner-lobb: alpha (0.25), fm (6). Density outside the shapes is 0.
// ct-body takes no size: dims ([512, 512, 1734], each 8..2048), seed (1), noise (60, at most 10000).
//
// molecular-density takes no size: file (required: PDB/mmCIF/GRO/XYZ, optionally .gz, read by
// load_particles with its defaults: the deposited coordinates, no biological assembly, hydrogens kept;
// a relative path is taken relative to `base_dir`, the scene file's folder), spacing (voxel edge in Å,
// 1.5), sigma (Gaussian width in Å, 1.5; the map's resolution is about 2.35 sigma, its FWHM), padding
// (Å around the atoms' box, 3 sigma), weight ("atomic_number" or "uniform"). The density is
//   rho(x) = sum_a w_a exp(-|x - c_a|^2 / (2 sigma^2)),
// unnormalised and dimensionless (w_a = the atom's atomic number, an unrecognised element counting as
// carbon, 6; or 1), each atom truncated at 3 sigma from its centre (the missing tail is below
// exp(-4.5) w_a = 0.011 w_a per atom). Voxel (i, j, k) lies at origin + spacing * (i, j, k) with origin =
// the atoms' box corner minus padding, so the volume overlays the same file loaded as particles. Each
// dimension is at most 1024 voxels (an Error naming "spacing" otherwise). The splat runs in parallel
// over z-slabs and gives the same bytes for any thread count.
Volume make_procedural_volume(const nlohmann::json& spec, const std::string& base_dir = "");
// The parameters of a "ct-body" spec, each of its dims from 8 to `max_dim` (2048 for a volume held whole;
// `penumbra convert` streams larger ones slice by slice).
CtBodyParams ct_body_params(const nlohmann::json& spec, int max_dim = 2048);

}  // namespace penumbra
