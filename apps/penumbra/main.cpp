// penumbra: shadowed and ambient-occluded rendering of volumes and particles, every technique next to
// its exact reference. `penumbra --help` lists the commands.
#include <cstdio>
#include <exception>
#include <memory>
#include <string>

#include "commands.h"
#include "penumbra/core/error.h"
#include "penumbra/core/frame_memory.h"
#include "mpi_launch.h"
#include "penumbra_version.h"

int main(int argc, char** argv) {
  penumbra::keep_frame_memory_mapped();
  // Started by mpirun: every rank runs this same executable, and `render` renders data-parallel.
  std::unique_ptr<penumbra::MpiWorld> world;
  if (penumbra::MpiWorld::launched_by_mpirun()) world = std::make_unique<penumbra::MpiWorld>(argc, argv);
  CLI::App app{"penumbra: shadowed volume rendering, every technique measured against an exact reference"};
  app.set_version_flag("--version", std::string("penumbra ") + PENUMBRA_VERSION + " (" + PENUMBRA_GIT_DESCRIBE + ")");
  app.require_subcommand(1);
  penumbra::cli::add_render_command(app);
  penumbra::cli::add_view_command(app);
  penumbra::cli::add_demo_command(app);
  penumbra::cli::add_compare_command(app);
  penumbra::cli::add_montage_command(app);
  penumbra::cli::add_info_command(app);
  penumbra::cli::add_bench_command(app);
  penumbra::cli::add_techniques_command(app);
  penumbra::cli::add_select_command(app);
  penumbra::cli::add_convert_command(app);
  if (world) return penumbra::cli::run_on_all_ranks(app, argc, argv, *world);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const penumbra::Error& e) {
    std::fprintf(stderr, "penumbra: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "penumbra: error: %s\n", e.what());
    return 1;
  }
  return 0;
}
