// Where a file's voxels lie in the world, and how they become the renderer's grid.
//
// Every reader computes its file's index-to-world affine in one world frame, LPS (DICOM's and ITK's
// patient frame: +x towards the patient's left, +y posterior, +z superior; NIfTI's RAS becomes LPS by
// negating x and y), and hands it here with the voxels in the file's order. The renderer's grid is
// axis-aligned with positive spacing along +x, +y, +z (macrocells, gradients, SAT, shadow maps and MPI
// slabs all rely on it), so:
// - an affine whose every column lies along one world axis (a signed permutation of a diagonal: flips,
//   RAS/LPS, swapped axes), within kAxisCosineTolerance on the direction cosines, is honoured exactly
//   by reordering the voxels (axes permuted, reversed ones reversed; the origin at the new first voxel);
// - any other affine (a rotation, a shear such as a tilted gantry) is resampled trilinearly onto an
//   axis-aligned grid covering its world box at the smallest of its spacings, and a note says so.
// A singular or non-finite affine is an Error, as is a sparse (bricked) volume that needs reordering.
#pragma once

#include <array>
#include <cstddef>
#include <optional>
#include <string>

#include "penumbra/data/io/volume_io.h"

namespace penumbra {

// Off-axis direction cosines up to this (0.057°) are taken as 0; beyond it an affine is oblique. A
// NIfTI qform stores its rotation as a float32 quaternion whose first component is recomputed, which
// near a half turn (an axis swap with a flip) leaves cosines of up to about 5e-4 where 0 was meant;
// across 512 voxels the largest tilt taken as 0 moves the far edge by half a voxel.
constexpr double kAxisCosineTolerance = 1e-3;
// The largest grid an oblique volume is resampled onto.
constexpr std::size_t kMaxResampledBytes = std::size_t{8} << 30;
// ... and at most this many times the file's voxels (beyond a floor of kResampledVoxelFloor): a turn
// grows the box about 3x and a step of the finest spacing 10x for 10:1 anisotropic voxels, whereas an
// affine with one tiny spacing (a header error) would ask for millions of times more. The floor lets a
// thin slab (a few slices, tilted) grow further; it is kept small, as 2^24 voxels grown out of a 1x2x2
// file with one absurd spacing took over 10 s to resample in the sanitised fuzz build (fuzz_nrrd).
constexpr double kMaxResampledGrowth = 64;
constexpr double kResampledVoxelFloor = double{1 << 21};

// The stored axis w holds the file's axis file_axis[w], reversed when `reversed[w]`.
struct AxisPermutation {
  std::array<int, 3> file_axis{0, 1, 2};
  std::array<bool, 3> reversed{false, false, false};
  bool identity() const { return file_axis == std::array<int, 3>{0, 1, 2} && !reversed[0] && !reversed[1] && !reversed[2]; }
};

// The signed permutation `affine` is, or nothing when it is oblique. Error when it is singular or not finite.
std::optional<AxisPermutation> axis_permutation(const Affine& affine);

// The voxels of `file_grid` (dense, in the file's order; its spacing and origin are ignored) placed by
// `affine`: reordered or resampled as above, with spacing and origin of the stored grid. Records the
// affine and what was done in `info` (affine; orientation unless the reader described it; notes). The value range is left to the caller.
Volume place_volume(Volume file_grid, const Affine& affine, VolumeFileInfo& info);

// The stored grid's dimensions and origin when `affine` is a signed permutation (readers of a window
// of slices need them before reading).
std::array<int, 3> placed_dims(const std::array<int, 3>& file_dims, const AxisPermutation& p);
Vec3 placed_origin(const Affine& affine, const std::array<int, 3>& file_dims, const AxisPermutation& p);

// A window of slices (SliceChooser) in the file: what a reader of a format that can read part of its
// slices asks before reading.
struct FileWindow {
  std::optional<SliceRange> placed;  // the chosen slices of the placed grid: none without a choice, or when
                                     // the file is resampled (then known only after reading it whole)
  bool in_part = false;              // only the file's slices [file_first, file_first + count) are read:
                                     // the file's z is the placed z (reversed or not) and the window is not all of it
  int file_first = 0;
  int count = 0;                     // in_part: the window's slices; else the file's
};
// Checks the chosen slices against the placed grid (Error naming them).
FileWindow file_window(const SliceChooser* choose, const std::array<int, 3>& file_dims, const std::optional<AxisPermutation>& p);
// The file's slices [window.file_first, + window.count) (`file_slices`: dense, in the file's order) placed as the window
// of the whole grid `affine` and `file_dims` describe (Volume::is_window; its value range its own; `info` records the
// whole file's affine).
Volume place_window(Volume file_slices, const Affine& affine, const std::array<int, 3>& file_dims, const AxisPermutation& p,
                    const FileWindow& window, VolumeFileInfo& info);
// A volume read whole and placed, cut to the chosen slices when they are not all of it (`read.whole` then
// set); the value range is left to the caller.
Volume keep_chosen_slices(Volume placed, const SliceChooser* choose, const FileWindow& window, WindowRead* read);

}  // namespace penumbra
