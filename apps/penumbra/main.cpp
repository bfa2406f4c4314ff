// penumbra: shadowed and ambient-occluded rendering of volumes and particles, every technique next to
// its exact reference. `penumbra --help` lists the commands.
#include <malloc.h>

#include <cstdio>
#include <exception>

#include "commands.h"
#include "penumbra/core/error.h"

int main(int argc, char** argv) {
  // Frames allocate the same large buffers again and again (hit buffers, images: tens of MB at
  // 1920×1200). glibc would map and unmap each one, and the page faults of the fresh pages cost more
  // than the sphere splatting itself (measured: a 1 M-sphere frame 400 ms → 170 ms); keep them in the
  // heap and reuse them instead.
  mallopt(M_MMAP_THRESHOLD, 1 << 30);
  mallopt(M_TRIM_THRESHOLD, 1 << 30);
  CLI::App app{"penumbra: shadowed volume rendering, every technique measured against an exact reference"};
  app.require_subcommand(1);
  penumbra::cli::add_render_command(app);
  penumbra::cli::add_view_command(app);
  penumbra::cli::add_demo_command(app);
  penumbra::cli::add_compare_command(app);
  penumbra::cli::add_montage_command(app);
  penumbra::cli::add_info_command(app);
  penumbra::cli::add_bench_command(app);
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
