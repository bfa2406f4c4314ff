// The extinction-illumination suite of `penumbra bench` (paper 001's Tables 1–3), see bench_extinction.cpp.
#pragma once

#include <nlohmann/json.hpp>

#include <sstream>
#include <string>
#include <vector>

namespace penumbra::cli {

struct ExtinctionBenchOptions {
  std::string dir;                  // where the images go
  std::string data_dir;             // cranium_ct.nrrd, chest_ct.nrrd
  std::vector<std::string> datasets{"procedural", "cranium", "chest"};
  int repeats = 3;
  int size = 512;                   // frame width and height
  int max_sampled_size = 128;       // largest cache size the sampled-AO column is timed at
  std::vector<int> cache_sizes{64, 128, 192, 256};  // light-cache sizes of the build table
  int accuracy_cache = 64;          // cache size of the sat_cone vs densely sampled cone comparison
  int procedural_size = 256;        // the procedural data set: test-spheres of this size³
  int frame_cache = 0;              // light-cache resolution of the frame table; 0: the scene's (128)
};

// Appends the Markdown tables to `md` and the figures to out["extinction"].
void bench_extinction(const ExtinctionBenchOptions& options, std::ostringstream& md, nlohmann::json& out);

}  // namespace penumbra::cli
