// Molecular-dynamics trajectories: frames of atom positions streamed from disk, one frame at a time.
// Formats (by extension): GROMACS .xtc (compressed coordinates), CHARMM/NAMD .dcd, multi-model PDB
// (.pdb, .ent), multi-frame XYZ and GROMACS .gro; the text formats may be gzip-compressed (.gz).
// Multi-model mmCIF (.cif, .mmcif, .gz) is the exception: gemmi parses it whole, so its reader holds
// every model's positions.
// Positions are in ångström (penumbra's world unit), in the topology's atom order; the unit cell is
// given as MDAnalysis' `dimensions` (a, b, c in Å; alpha, beta, gamma in degrees). docs/trajectories.md
// describes the formats, the checks and `penumbra info --trajectory`.
#pragma once

#include <array>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "penumbra/core/math.h"

namespace penumbra {

struct TrajectoryFrame {
  std::vector<Vec3> positions;   // Å, in the topology's atom order
  double time_ps = 0;            // time in ps where the format stores it (XTC, DCD from its header, GRO "t="), else the frame index
  std::int64_t step = 0;         // MD step where stored (XTC, DCD from ISTART/NSAVC, GRO "step="), else the frame index
  bool has_box = false;          // a unit cell is stored for this frame
  std::array<float, 6> box{};    // a, b, c (Å), alpha, beta, gamma (degrees), as MDAnalysis' `dimensions`
};

// Frames streamed from disk: the reader holds one frame's buffers and an index of frame offsets that
// it builds when the file is opened, so any frame can be read in any order (mmCIF: every frame, held).
class TrajectoryReader {
public:
  virtual ~TrajectoryReader() = default;
  virtual std::string format() const = 0;            // "xtc", "dcd", "pdb", "mmcif", "xyz", "gro"
  virtual std::size_t frame_count() const = 0;
  virtual std::size_t atom_count() const = 0;
  // Random access; throws Error naming the file and the frame on malformed data.
  virtual void read_frame(std::size_t index, TrajectoryFrame& out) = 0;
  virtual std::size_t memory_bytes() const = 0;      // the index and buffers the reader holds, for --stats
};

// The trajectory format of a file name ("xtc", "dcd", "pdb", "mmcif", "xyz", "gro"; a .gz suffix is
// allowed for the text formats), or "" when the extension is none of these.
std::string trajectory_file_format(const std::string& path);

// Opens by extension (.xtc, .dcd, .pdb/.ent with MODEL records or one model, .cif/.mmcif with one or
// more models, .xyz, .gro; .gz allowed for the text formats) and indexes the frames. Throws Error
// naming the file (and frame where there is one) and what was expected on unreadable, truncated or lying
// input. expected_atoms > 0: every frame must hold that many atoms (the topology's), else an Error
// naming file, frame, found and expected.
std::unique_ptr<TrajectoryReader> open_trajectory(const std::string& path, std::size_t expected_atoms = 0);
// Several files read one after another as one trajectory (frames in the order given); every file must
// hold the same number of atoms. Only one file is open at a time.
std::unique_ptr<TrajectoryReader> open_trajectory(const std::vector<std::string>& paths, std::size_t expected_atoms = 0);

}  // namespace penumbra
