#include "bench_provenance.h"

#include <unistd.h>

#include <ctime>
#include <fstream>
#include <set>
#include <sstream>
#include <utility>

#include "penumbra_version.h"

namespace penumbra::cli {
namespace {

std::string trim(const std::string& s) {
  const auto a = s.find_first_not_of(" \t"), b = s.find_last_not_of(" \t\n");
  return a == std::string::npos ? std::string() : s.substr(a, b - a + 1);
}

}  // namespace

Provenance current_provenance(int threads_used) {
  Provenance p;
  p.commit = PENUMBRA_GIT_DESCRIBE;
  char buf[32];
  const std::time_t t = std::time(nullptr);
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  p.date = buf;
  std::ifstream in("/proc/cpuinfo");
  std::string line, physical_id;
  std::set<std::pair<std::string, std::string>> cores;
  while (std::getline(in, line)) {
    const auto colon = line.find(':');
    if (colon == std::string::npos) continue;
    const std::string key = trim(line.substr(0, colon)), value = trim(line.substr(colon + 1));
    if (key == "model name" && p.cpu_model.empty()) p.cpu_model = value;
    if (key == "physical id") physical_id = value;
    if (key == "core id") cores.insert({physical_id, value});
  }
  if (p.cpu_model.empty()) p.cpu_model = "unknown CPU";
  p.hardware_threads = static_cast<int>(sysconf(_SC_NPROCESSORS_ONLN));
  p.cores = cores.empty() ? p.hardware_threads : static_cast<int>(cores.size());
  p.threads_used = threads_used;
  p.memory = std::to_string((sysconf(_SC_PHYS_PAGES) * sysconf(_SC_PAGE_SIZE)) / (1024LL * 1024 * 1024)) + " GiB";
  std::ifstream load("/proc/loadavg");
  std::string a, b, c;
  if (load >> a >> b >> c) p.load_average = a + " " + b + " " + c;
  else p.load_average = "unknown";
  return p;
}

nlohmann::json to_json(const Provenance& p) {
  return {{"commit", p.commit},       {"date", p.date},
          {"cpu_model", p.cpu_model}, {"cores", p.cores},
          {"hardware_threads", p.hardware_threads}, {"threads_used", p.threads_used},
          {"memory", p.memory},       {"load_average", p.load_average}};
}

std::string to_markdown(const Provenance& p) {
  std::ostringstream s;
  s << "Commit `" << p.commit << "`, " << p.date << ". Machine: " << p.cpu_model << ", " << p.cores << " cores, "
    << p.hardware_threads << " hardware threads, " << p.memory << "; " << p.threads_used
    << " threads used; load average " << p.load_average << " at the start.";
  return s.str();
}

}  // namespace penumbra::cli
