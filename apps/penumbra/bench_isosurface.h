// The isosurface suite of `penumbra bench` (paper 002, Livnat & Tricoche, Table 1), see
// bench_isosurface.cpp.
#pragma once

#include <nlohmann/json.hpp>

#include <array>
#include <sstream>
#include <string>
#include <vector>

namespace penumbra::cli {

struct IsosurfaceBenchOptions {
  std::string dir;       // where the images go
  std::string data_dir;  // cranium_ct.nrrd, chest_ct.nrrd
  std::vector<std::string> datasets{"ct-body", "cranium", "chest"};
  std::array<int, 3> body_dims{512, 512, 1734};  // the procedural Visible-Woman-sized volume
  int repeats = 3;       // frames per measurement (the fastest is kept)
  int size = 512;        // frame and light buffer size (the paper's 512²)
  bool mesh = true;      // also time the marching-cubes baseline
};

// Appends the Markdown tables to `md` and the figures to out (the caller passes out["isosurface"]).
void bench_isosurface(const IsosurfaceBenchOptions& options, std::ostringstream& md, nlohmann::json& out);

}  // namespace penumbra::cli
