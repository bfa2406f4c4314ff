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

}  // namespace penumbra
