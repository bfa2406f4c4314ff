// The deep-shadow-map suite of `penumbra bench` (issue 12 §4): CSSM against both deep shadow map
// layouts and the classic map, at the CSSM paper's settings and at equal memory; see bench_dsm.cpp.
#pragma once

#include <nlohmann/json.hpp>

#include <sstream>
#include <string>
#include <utility>
#include <vector>

namespace penumbra::cli {

struct DsmBenchOptions {
  std::string dir;                                            // where the images go
  std::vector<std::pair<std::string, nlohmann::json>> scenes;  // name, scene
  int resolution = 1024;                                      // the paper's map resolution (§4, Fig. 3)
  int repeats = 3;
  int size = 512;                                             // frame width and height
};

// Appends the Markdown tables to `md` and the figures to out (the caller passes out["dsm"]).
void bench_dsm(const DsmBenchOptions& options, std::ostringstream& md, nlohmann::json& out);

}  // namespace penumbra::cli
