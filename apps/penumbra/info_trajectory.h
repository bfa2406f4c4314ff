// `penumbra info` for trajectories (.xtc, .dcd, or any .pdb/.cif/.xyz/.gro given with --trajectory):
// format, atoms, frames, time range and the first frame's unit cell; with --frame K that frame's time,
// step and cell; with --positions OUT (.npy or .txt) that frame's coordinates in Å, for comparing with
// other readers (tests/python/test_trajectory_oracle.py); with --read-all the reading speed.
#pragma once

#include <cstddef>
#include <string>

namespace penumbra::cli {

struct TrajectoryInfoOptions {
  std::string file;
  long long frame = -1;    // < 0: none asked for (--positions then writes frame 0)
  std::string positions;  // "" or a path ending in .npy or .txt
  bool read_all = false;
};

void info_trajectory(const TrajectoryInfoOptions& o);

}  // namespace penumbra::cli
