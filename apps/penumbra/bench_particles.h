// The particle suite of `penumbra bench` (paper 003, Implicit Sphere Shadow Maps, Fig. 8), see
// bench_particles.cpp.
#pragma once

#include <nlohmann/json.hpp>

#include <sstream>
#include <string>
#include <vector>

namespace penumbra::cli {

struct ParticleBenchOptions {
  std::string dir;       // where the images go
  std::string data_dir;  // 1tii.pdb, 1af6.pdb, 1aon.pdb.gz, bace1_dppc.gro.gz, 3j6r.pdb.gz, 1m4x.pdb.gz
  std::vector<std::string> datasets{"1tii", "1af6", "1aon", "bace1", "3j6r", "1m4x"};
  int repeats = 3;       // frames per median (after one warm-up frame)
  int width = 1920;      // frame size (the paper's 1920×1200)
  int height = 1200;
  // Above this many spheres the ray-traced references are rendered once at a reduced frame of at most
  // `reference_pixels` pixels (same aspect), and the error is measured there.
  std::size_t full_reference_spheres = 100000;
  std::size_t reference_pixels = 480 * 300;
  // Above this many spheres (1m4x) only LL, ISSM and ISSM + AO are rendered, one frame each.
  std::size_t huge_spheres = 4000000;
};

// Appends the Markdown tables to `md` and the figures to out (the caller passes out["particles"]).
void bench_particles(const ParticleBenchOptions& options, std::ostringstream& md, nlohmann::json& out);

}  // namespace penumbra::cli
