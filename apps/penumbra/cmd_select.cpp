// `penumbra select FILE SELECTION [--trajectory T… --frame K] [--indices OUT.txt]`: the atoms of a
// particle file that a selection (docs/selections.md) keeps, on the file's coordinates or on a frame
// of a trajectory (with that frame's box), and how long the evaluation took. The same string works in
// MDAnalysis's select_atoms; tests/python/test_selection_oracle.py compares the two.
#include <chrono>
#include <cstdio>
#include <string>
#include <vector>

#include "commands.h"
#include "penumbra/core/error.h"
#include "penumbra/core/replace_file.h"
#include "penumbra/data/io/particle_io.h"
#include "penumbra/data/io/trajectory_io.h"
#include "penumbra/data/selection/selection.h"

namespace penumbra::cli {

void add_select_command(CLI::App& app) {
  struct Options {
    std::string file, selection, indices;
    std::vector<std::string> trajectory;
    std::size_t frame = 0;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("select", "Print how many atoms of a particle file a selection keeps (MDAnalysis's selection language)");
  cmd->add_option("file", o->file, "Particle file: the topology (PDB, mmCIF, GRO, XYZ)")->required();
  cmd->add_option("selection", o->selection, "Selection, e.g. \"protein and not name H*\" (docs/selections.md)")->required();
  cmd->add_option("--trajectory", o->trajectory, "Evaluate on a frame of this trajectory (one or more files, read as one)");
  cmd->add_option("--frame", o->frame, "Trajectory frame (from 0)")->check(CLI::NonNegativeNumber);
  cmd->add_option("--indices", o->indices, "Write the selected atoms' 0-based indices to this text file, one a line");
  cmd->callback([o] {
    const auto selection = with_context("selection", [&] { return parse_selection(o->selection); });
    const auto file = read_particle_file(o->file);
    const AtomTopology& topology = topology_of(*file);
    std::vector<Vec3> positions = positions_of(*file);
    std::optional<CellDimensions> cell = topology.unit_cell;
    if (!o->trajectory.empty()) {
      auto reader = open_trajectory(o->trajectory, topology.size());
      if (o->frame >= reader->frame_count())
        throw Error("--frame " + std::to_string(o->frame) + ": the trajectory has " + std::to_string(reader->frame_count()) + " frames");
      TrajectoryFrame frame;
      reader->read_frame(o->frame, frame);
      positions = std::move(frame.positions);
      cell = frame.has_box ? std::optional<CellDimensions>(frame.box) : std::nullopt;
    }
    const auto start = std::chrono::steady_clock::now();
    const std::vector<std::uint32_t> selected = selection->evaluate(topology, positions, cell);
    const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    std::printf("atoms       %zu\nselected    %zu\nevaluated   %.3f ms\n", topology.size(), selected.size(), ms);
    if (!o->indices.empty()) {
      std::string text;
      for (const std::uint32_t i : selected) text += std::to_string(i) + "\n";
      with_context("--indices " + o->indices, [&] { replace_file_contents(o->indices, text); });
    }
  });
}

}  // namespace penumbra::cli
