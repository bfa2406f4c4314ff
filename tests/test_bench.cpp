// `penumbra bench --quick` end to end (issue 12 §2, §5): every suite runs on tiny data, writes bench.md and
// bench.json and the images it names, has a row for every technique it claims to compare, and records
// where its figures come from (commit, date, CPU, cores, threads).
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>

#include "cli_run.h"
#include "test_scenes.h"

using namespace penumbra;
using namespace penumbra::test;
namespace fs = std::filesystem;

namespace {

int count(const std::string& haystack, const std::string& needle) {
  int n = 0;
  for (auto p = haystack.find(needle); p != std::string::npos; p = haystack.find(needle, p + 1)) ++n;
  return n;
}

bool finite_number(const nlohmann::json& j) { return j.is_number() && std::isfinite(j.get<double>()); }

}  // namespace

TEST(Bench, QuickModeProducesWhatItClaims) {
  ScratchDir dir;
  const std::string out = dir.file("bench"), log = dir.file("log.txt");
  const std::string cmd = std::string("'") + PENUMBRA_CLI + "' bench --quick --threads 2 -o '" + out + "' >'" + log + "' 2>&1";
  const int raw = std::system(cmd.c_str());
  ASSERT_TRUE(WIFEXITED(raw) && WEXITSTATUS(raw) == 0) << slurp(log);
  ASSERT_TRUE(fs::exists(out + "/bench.md"));
  ASSERT_TRUE(fs::exists(out + "/bench.json"));
  const std::string md = slurp(out + "/bench.md");
  const nlohmann::json j = nlohmann::json::parse(slurp(out + "/bench.json"));
  EXPECT_TRUE(j.at("quick").get<bool>());

  // Provenance: present, non-empty, and the same in both outputs.
  const nlohmann::json& p = j.at("provenance");
  for (const char* k : {"commit", "date", "cpu_model", "memory", "load_average"}) {
    ASSERT_TRUE(p.at(k).is_string()) << k;
    EXPECT_FALSE(p[k].get<std::string>().empty()) << k;
  }
  if (std::system("git --version >/dev/null 2>&1") == 0) {
    EXPECT_NE(p["commit"], "unknown") << "the build should know its commit (git describe at build time)";
  }
  for (const char* k : {"cores", "hardware_threads", "threads_used"}) EXPECT_GT(p.at(k).get<int>(), 0) << k;
  EXPECT_EQ(p["threads_used"], 2);
  EXPECT_LE(p["cores"].get<int>(), p["hardware_threads"].get<int>());
  EXPECT_EQ(p["date"].get<std::string>().size(), 20u) << "ISO 8601 UTC, e.g. 2026-12-01T19:40:00Z";
  EXPECT_NE(md.find("Commit `" + p["commit"].get<std::string>() + "`"), std::string::npos) << md.substr(0, 400);
  EXPECT_NE(md.find(p["cpu_model"].get<std::string>()), std::string::npos);

  // Every suite ran: a section in bench.md and figures in bench.json.
  std::set<std::string> suites;
  for (const auto& s : j.at("suites")) suites.insert(s.get<std::string>());
  for (const char* s : {"cssm", "dsm", "extinction", "isosurface"}) EXPECT_TRUE(suites.count(s)) << s;
  EXPECT_EQ(suites.count("particles") == 1, fs::exists(std::string(PENUMBRA_SHARED_DATA_DIR) + "/1tii.pdb") ||
                                                 (std::getenv("PENUMBRA_DATA_DIR") && fs::exists(std::string(std::getenv("PENUMBRA_DATA_DIR")) + "/1tii.pdb")));

  // cssm suite: every technique at every resolution, with time, memory and error; the images it names.
  const nlohmann::json& cssm = j.at("datasets").at("test-spheres");
  std::set<std::pair<std::string, int>> seen;
  for (const auto& r : cssm.at("runs")) {
    seen.insert({r.at("technique").get<std::string>(), r.at("resolution").get<int>()});
    for (const char* k : {"build_ms", "render_ms", "rmse", "psnr"}) EXPECT_TRUE(finite_number(r.at(k))) << k;
    EXPECT_GT(r.at("memory_bytes").get<double>(), 0);
    EXPECT_TRUE(fs::exists(out + "/test-spheres_" + r["technique"].get<std::string>() + "_" +
                           std::to_string(r["resolution"].get<int>()) + ".png"));
  }
  for (const char* t : {"shadow_map", "deep_shadow_map", "cssm"})
    for (const int res : {48, 64}) EXPECT_TRUE(seen.count({t, res})) << t << " at " << res;
  EXPECT_TRUE(fs::exists(out + "/test-spheres_ray_traced.png"));
  EXPECT_EQ(count(md, "\n| 48² |"), 4) << "one row per table (build, render, memory, error)";

  // dsm suite: 4 techniques × (paper settings + 2 equal-memory budgets), a Markdown row for each, every
  // equal-memory map within its budget, and the verdict on the paper's claim for both layouts.
  const nlohmann::json& dsm = j.at("dsm").at("datasets").at("test-spheres");
  ASSERT_EQ(dsm.at("runs").size(), 12u);
  std::map<std::string, int> per_setting;
  std::map<std::string, double> paper_bytes;
  for (const auto& r : dsm["runs"]) {
    const std::string setting = r.at("setting"), label = r.at("label");
    ++per_setting[setting];
    for (const char* k : {"build_ms", "render_ms", "rmse", "psnr"}) EXPECT_TRUE(finite_number(r.at(k))) << k;
    EXPECT_NE(md.find("| " + setting + " | " + label + " | " + std::to_string(r["resolution"].get<int>()) + "² |"), std::string::npos)
        << setting << " / " << label;
    if (setting.rfind("paper settings", 0) == 0) paper_bytes[label] = r.at("memory_bytes").get<double>();
  }
  ASSERT_EQ(per_setting.size(), 3u);
  for (const auto& [setting, n] : per_setting) EXPECT_EQ(n, 4) << setting;
  for (const char* label : {"shadow_map", "deep_shadow_map per_channel, 3 nodes", "deep_shadow_map shared_depth, 3 nodes",
                            "cssm, 13 offsets"})
    EXPECT_TRUE(paper_bytes.count(label)) << label;
  for (const auto& r : dsm["runs"]) {
    const std::string setting = r["setting"];
    const double budget = setting.find("cssm's") != std::string::npos ? paper_bytes["cssm, 13 offsets"]
                          : setting.find("paper's DSM") != std::string::npos ? paper_bytes["deep_shadow_map shared_depth, 3 nodes"]
                                                                               : -1;
    if (budget > 0) {
      EXPECT_LE(r["memory_bytes"].get<double>(), budget) << setting << " / " << r["label"];
    }
  }
  EXPECT_EQ(count(md, "the claim (better with less memory)"), 2);
  EXPECT_TRUE(dsm.at("claim").size() == 2u);
  EXPECT_TRUE(fs::exists(out + "/dsm_test-spheres_dsm_shared_depth_64.png"));

  // extinction suite: one build row per cache size and the frame table.
  const nlohmann::json& ext = j.at("extinction");
  EXPECT_EQ(ext.at("caches").at("procedural").size(), 2u);
  EXPECT_TRUE(ext.at("frames").at("procedural").is_object());
  EXPECT_NE(md.find("### procedural: frames at 40²"), std::string::npos);

  // isosurface suite: the data set's rows.
  EXPECT_FALSE(j.at("isosurface").empty());
  EXPECT_NE(md.find("### ct-body"), std::string::npos);

  if (suites.count("particles")) {
    EXPECT_TRUE(j.at("particles").at("datasets").contains("1tii"));
  }
}
