#include "mpi_launch.h"

#include <cstdio>
#include <string>

namespace penumbra::cli {
namespace {
MpiWorld* g_world = nullptr;
std::function<void()> g_command;
}  // namespace

MpiWorld* mpi_world() { return g_world; }

void defer_to_all_ranks(std::function<void()> command) { g_command = std::move(command); }

int run_on_all_ranks(CLI::App& app, int argc, char** argv, MpiWorld& world) {
  g_world = &world;
  std::string error;
  bool help = false;
  const std::string command = argc > 1 ? argv[1] : "";
  if (command != "render" && command != "--help" && command != "-h") {
    error = "under mpirun only `penumbra render` runs (data-parallel), not '" + command + "'";
  } else {
    try {
      app.parse(argc, argv);
      if (!g_command) error = "nothing to render";
    } catch (const CLI::ParseError& e) {
      if (e.get_exit_code() == 0) {
        help = true;
        if (world.rank() == 0) app.exit(e);
      } else {
        error = e.what();
      }
    } catch (const std::exception& e) {
      error = e.what();
    }
  }
  error = world.agree(error);
  if (error.empty() && !help) {
    try {
      g_command();  // agrees on its own errors: every rank throws the same message
    } catch (const std::exception& e) {
      error = e.what();
    }
  }
  g_world = nullptr;
  if (error.empty()) return 0;
  std::fprintf(stderr, "penumbra: error: %s\n", error.c_str());
  return 1;
}

}  // namespace penumbra::cli
