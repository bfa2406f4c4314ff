// penumbra under mpirun: the same executable, started on every rank. Each rank parses its own command
// line; only `render` runs data-parallel, and it runs once every rank has parsed its options and agreed
// that none failed (so a rank with a bad option or a missing file cannot leave the others waiting in a
// collective: all stop with the lowest failing rank's message).
#pragma once

#include <CLI/CLI.hpp>

#include <functional>

#include "penumbra/distributed/mpi_world.h"

namespace penumbra::cli {

// The ranks when started by mpirun; null otherwise.
MpiWorld* mpi_world();

// Called by a command's callback under mpirun: the work to run once all ranks have parsed.
void defer_to_all_ranks(std::function<void()> command);

// main() under mpirun: parses, agrees, runs the deferred command; the exit status.
int run_on_all_ranks(CLI::App& app, int argc, char** argv, MpiWorld& world);

}  // namespace penumbra::cli
