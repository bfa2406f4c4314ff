// Built-in scenes for `penumbra demo`, `penumbra bench` and the tests: procedural data, so they need
// no files (the CT scene reads ../shared/data/cranium_ct.nrrd and is used only where it exists).
#pragma once

#include <nlohmann/json.hpp>

#include <string>

namespace penumbra {

// The CSSM paper's synthetic scene: test-spheres (size³ voxels, coloured by the "test-spheres" preset)
// over a white floor, lit by a point light from above.
nlohmann::json test_spheres_scene(int size = 128);

// The paper's Figure 3 kind of scene: a head CT with semi-transparent soft tissue and bone over a
// floor, lit from above. `path` is the cranium_ct.nrrd file.
nlohmann::json cranium_scene(const std::string& path);

// The chest CT (chest_ct.nrrd, uint8) with lungs, ribs and spine under a spot light (scenes/chest.json).
nlohmann::json chest_scene(const std::string& path);

// Particles: 3,000 random spheres over a floor, lit from above (scenes/spheres-floor.json), with ISSM
// and particle AO.
nlohmann::json spheres_floor_scene();

// A molecule file (e.g. 1aon.pdb.gz) coloured by chain with ISSM and particle AO, framed closely.
nlohmann::json molecule_scene(const std::string& path);

// The procedural ct-body CT (nx × ny × nz voxels; 512 × 512 × 1734 is the Visible Woman's size) as a
// bone isosurface of points with light-pass shadows from a point light (scenes/ct-body.json).
nlohmann::json ct_body_scene(int nx = 512, int ny = 512, int nz = 1734);

}  // namespace penumbra
