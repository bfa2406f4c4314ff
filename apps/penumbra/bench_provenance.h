// Where a `penumbra bench` figure comes from: the commit the binary was built from (`git describe
// --always --dirty`, generated at build time by cmake/version_header.cmake), the date and time, the CPU
// model, its physical cores, its hardware threads, the threads the bench used, and the load average
// (other processes disturb timings). Every bench output carries it: bench.md's first lines and
// bench.json's "provenance".
#pragma once

#include <nlohmann/json.hpp>

#include <string>

namespace penumbra::cli {

struct Provenance {
  std::string commit;      // git describe --always --dirty at build time
  std::string date;        // UTC, ISO 8601: 2026-12-01T19:40:00Z
  std::string cpu_model;   // /proc/cpuinfo "model name"
  int cores = 0;           // physical cores (distinct physical id/core id pairs; hardware threads if unknown)
  int hardware_threads = 0;  // logical CPUs online
  int threads_used = 0;    // worker threads of this run (--threads)
  std::string memory;      // "23 GiB"
  std::string load_average;  // /proc/loadavg, 1/5/15 min, at the start
};

Provenance current_provenance(int threads_used);
nlohmann::json to_json(const Provenance& p);
// One Markdown paragraph: "Commit …, date …, CPU … (N cores, M hardware threads), K threads used, …".
std::string to_markdown(const Provenance& p);

}  // namespace penumbra::cli
