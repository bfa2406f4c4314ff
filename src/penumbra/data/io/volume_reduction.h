// A volume file larger than its memory budget, opened reduced: the finest power-of-two reduction whose
// voxels and macrocells (volume_held_bytes) fit, each voxel the mean of a 2^l × 2^l × 2^l block of the
// file's voxels (fewer at odd edges; integers rounded half up), computed while the file is read a slab
// of slices at a time (load_volume_window), so that the file is never held whole. What an OME-Zarr
// pyramid's level gives (zarr_loader.cpp) for a file that has no pyramid: what load_volume_window
// reads in part (reads_slices_in_part: NRRD, NIfTI, TIFF stacks, HDF5 datasets, raw files);
// `penumbra convert` writes the pyramid when levels are to be chosen.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "penumbra/data/io/volume_io.h"

namespace penumbra {

// The reduced volume when the file's volume_held_bytes exceed options.memory_budget (> 0), with its format
// and notes in `info` saying by how much and why; nothing when the file fits, or when its format cannot be read in
// slabs (it is then read whole by load_volume and checked against the budget there). Error naming the
// file when it cannot be read, or when even the coarsest reduction (one voxel along the longest axis)
// does not fit.
std::optional<Volume> load_reduced_to_fit(const std::string& path, const VolumeLoadOptions& options, VolumeFileInfo& info);

// The levels of a file that load_reduced_to_fit opened as `opened`: level l the reduction by 2^l (0 the
// file itself, each axis's factor capped at its length), up to and including the opened one, placed as
// the reduction places them; empty when `opened` is no reduction of the file (or the file reads only
// whole). What a refined view of the file chooses among (render/view_refinement.h).
std::vector<LevelGrid> reduced_level_grids(const std::string& path, const VolumeLoadOptions& options, const Volume& opened);
// Voxels [lo, hi) of level `level` of the file (as reduced_level_grids numbers them; `file_level` its
// level 0, so that the header is not read again for each box), placed where they
// lie: each the mean of its block, computed as load_reduced_to_fit computes it (so a box equals that
// part of the opened level exactly), from the slices of the file under the box, read a slab at a time.
// `held`: a box of the same level in memory whose x and y cover this one's: the slices both hold are
// copied from it (`read->bytes_reused`) and only the others read. Error naming the file for a box
// outside the level.
Volume load_reduced_box(const std::string& path, const VolumeLoadOptions& options, const LevelGrid& file_level, int level,
                        const std::array<std::int64_t, 3>& lo, const std::array<std::int64_t, 3>& hi, WindowRead* read = nullptr,
                        const HeldBox* held = nullptr);

}  // namespace penumbra
