// Runs the built `penumbra` binary (PENUMBRA_CLI) with stdout and stderr captured, for the tests of the
// command line (test_cli.cpp) and of the shipped scenes and demo (test_shipped.cpp).
#pragma once

#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace penumbra::test {

struct CliRun {
  int status = -1;  // exit status (128 + signal when killed)
  std::string out, err;
};

inline std::string slurp(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

inline std::string quote(const std::string& s) { return "'" + s + "'"; }

// Runs `LAUNCHER penumbra ARGS` (the launcher e.g. "mpirun -np 2 ") with stdout and stderr captured in
// files outside any scratch directory of the test (so that such a directory holds only what the
// command itself wrote).
inline CliRun penumbra_cli_with_launcher(const std::string& launcher, const std::string& args) {
  static int counter = 0;
  namespace fs = std::filesystem;
  const fs::path logs = fs::temp_directory_path() / ("penumbra_cli_logs_" + std::to_string(::getpid()));
  fs::create_directories(logs);
  const std::string out = (logs / ("out" + std::to_string(counter) + ".txt")).string();
  const std::string err = (logs / ("err" + std::to_string(counter) + ".txt")).string();
  ++counter;
  const std::string cmd = launcher + quote(PENUMBRA_CLI) + " " + args + " >" + quote(out) + " 2>" + quote(err);
  const int raw = std::system(cmd.c_str());
  CliRun r;
  r.status = WIFEXITED(raw) ? WEXITSTATUS(raw) : 128 + (WIFSIGNALED(raw) ? WTERMSIG(raw) : 0);
  r.out = slurp(out);
  r.err = slurp(err);
  std::error_code ec;
  fs::remove(out, ec);
  fs::remove(err, ec);
  fs::remove(logs, ec);  // only when empty
  return r;
}

inline CliRun penumbra_cli(const std::string& args) { return penumbra_cli_with_launcher("", args); }

}  // namespace penumbra::test
