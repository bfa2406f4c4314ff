// The slices of a DICOM folder grouped into series, one chosen, checked to be one grid, and placed:
// sorted along the slice normal, evenly spaced (the step fitted through all positions), and given the
// affine (patient LPS) by which the loader places them (volume_placement.h). Internal to the DICOM reader (dicom_loader.cpp).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/data/io/dicom_slice.h"
#include "penumbra/data/io/volume_io.h"

namespace penumbra::dicom {

struct Series {
  std::string uid, description, modality;
  std::optional<long> number;
  std::vector<Slice> slices;
};

// "0: UID number N "description" CT, 120 slices of 512x512 (rows x columns)"
std::string series_line(std::size_t index, const Series& s);
// Series in a stable order: by SeriesNumber, then UID (the order of the files does not matter).
std::vector<Series> group_series(std::vector<Slice> slices);
// The series `wanted` names (a SeriesInstanceUID or an index; empty: the only one, or the largest with a
// note), or Error listing them.
std::size_t choose_series(const std::vector<Series>& all, const std::string& wanted, VolumeFileInfo& info);
// The slices of one series share their size, type and orientation (Error naming the first that differs).
void check_consistent(const std::vector<Slice>& slices);

// How the sorted slices become the file's grid: voxel (column i, row j, slice k) goes to index
// col[i] + row[j] + slice[k]; the grid's dimensions and its affine (LPS), which places it.
struct Layout {
  std::vector<const Slice*> slices;  // sorted by position along the normal
  std::array<int, 3> dims{};
  Affine affine;
  std::vector<std::int64_t> col, row, slice;
};

Layout arrange(const std::vector<Slice>& input, VolumeFileInfo& info);

}  // namespace penumbra::dicom
