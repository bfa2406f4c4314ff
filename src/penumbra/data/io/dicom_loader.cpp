// DICOM series (a folder of slices or a list of slice files). GDCM trusts the lengths in a file (a
// corrupt length makes it allocate and zero up to 4 GB) and asserts on malformed attributes, so GDCM
// never parses a file: every file is walked here (its elements, sequences and pixel-data fragments must
// nest properly and fit in the file) and the attributes the volume needs are read on the way. Native
// pixel data is then read here and RLE decoded here (GDCM's RLE decoder asserts or reads out of bounds
// on corrupt segments); only JPEG and JPEG-LS fragments go to GDCM's codecs, in an image assembled from
// the checked attributes, after the codestream's header has been checked against Rows and Columns.
// JPEG 2000 fragments go to OpenJPEG directly (jpeg2000_decode.h), not to GDCM's JPEG 2000 codec, after
// the same check of their header. Slices are grouped by SeriesInstanceUID, sorted by
// ImagePositionPatient along the slice normal and checked to be evenly spaced; the rescale is applied
// per slice. An axis-aligned series is permuted and flipped so that the volume's axes are patient +x,
// +y, +z (LPS); an oblique one keeps its grid, without its rotation.
// The reader's parts: dicom_slice.h (one file walked and checked), dicom_series.h (series grouped,
// chosen and placed), dicom_pixels.h (pixels decoded and rescaled).
#include <gdcmTrace.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/data/io/dicom_pixels.h"
#include "penumbra/data/io/dicom_series.h"
#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/dicom_slice.h"
#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/io/volume_placement.h"

namespace penumbra {

using dicom::Layout;
using dicom::Series;
using dicom::Slice;

namespace {

void quiet_gdcm() {
  static const bool done = [] {
    gdcm::Trace::SetDebug(false);
    gdcm::Trace::SetWarning(false);
    gdcm::Trace::SetError(false);
    return true;
  }();
  (void)done;
}

// Whether every rescaled value the slices' stored bits can hold fits int16: a window of slices then has
// the type the whole series has without decoding the others.
bool rescale_fits_int16(const std::vector<const Slice*>& slices) {
  for (const Slice* s : slices) {
    const double lo = s->is_signed ? -std::ldexp(1.0, s->bits_stored - 1) : 0.0;
    const double hi = s->is_signed ? std::ldexp(1.0, s->bits_stored - 1) - 1 : std::ldexp(1.0, s->bits_stored) - 1;
    const double a = lo * s->slope + s->intercept, b = hi * s->slope + s->intercept;
    if (std::min(a, b) < -32768 || std::max(a, b) > 32767) return false;
  }
  return true;
}

// The layout of slices [first, first + count) of `L`'s grid: those slices, placed by the same affine moved
// to the first of them.
dicom::Layout window_layout(const dicom::Layout& L, int first, int count) {
  dicom::Layout W = L;
  W.slices.assign(L.slices.begin() + first, L.slices.begin() + first + count);
  W.dims[2] = count;
  W.slice.resize(static_cast<std::size_t>(count));  // slice k starts at k × columns × rows in either grid
  for (int d = 0; d < 3; ++d) W.affine.offset[d] += first * L.affine.linear[d][2];
  return W;
}

}  // namespace

Volume load_dicom_volume(const std::vector<std::string>& paths, const std::string& series, VolumeFileInfo* info_out,
                         const std::string& confine_to, const SliceChooser* choose, WindowRead* read) {
  quiet_gdcm();
  if (read) *read = WindowRead{};
  VolumeFileInfo local;
  VolumeFileInfo& info = info_out ? *info_out : local;
  info.format = "dicom";

  // The slices: every DICOM image in a folder and its subfolders (as exports from scanners and PACS
  // nest them: DICOM/ST000/SE001/IM0001, often without an extension; other files skipped), or the
  // files given.
  std::vector<Slice> slices;
  std::error_code ec;
  if (paths.size() == 1 && std::filesystem::is_directory(paths[0], ec)) {
    constexpr int kMaxDepth = 8;
    constexpr std::size_t kMaxFiles = 200000;
    std::vector<std::filesystem::path> files;
    try {
      namespace fs = std::filesystem;
      for (auto it = fs::recursive_directory_iterator(paths[0], fs::directory_options::skip_permission_denied);
           it != fs::recursive_directory_iterator(); ++it) {
        if (it.depth() >= kMaxDepth) it.disable_recursion_pending();
        if (std::error_code entry_ec; it->is_regular_file(entry_ec)) files.push_back(it->path());
        if (files.size() > kMaxFiles)
          throw Error("holds more than " + std::to_string(kMaxFiles) + " files (expected a folder of DICOM slices)");
      }
    } catch (const std::filesystem::filesystem_error& e) {
      throw Error("cannot list the folder (" + e.code().message() + ")");
    }
    std::sort(files.begin(), files.end());
    for (const auto& file : files) io_detail::check_inside(file, confine_to, "slice");  // a link in the folder to a file elsewhere
    for (const auto& file : files)
      if (auto s = dicom::read_slice(file.string(), file.lexically_relative(paths[0]).generic_string(), true)) slices.push_back(std::move(*s));
    if (slices.empty())
      throw Error("none of the " + std::to_string(files.size()) + " files in the folder and its subfolders is a DICOM image "
                  "(expected a folder of DICOM slices)");
    if (slices.size() < files.size())
      info.notes.push_back(files.size() - slices.size() == 1 ? std::string("1 file in the folder is not a DICOM image: skipped")
                                                            : std::to_string(files.size() - slices.size()) + " files in the folder are not DICOM images: skipped");
  } else {
    for (const std::string& p : paths) slices.push_back(*dicom::read_slice(p, p, false));
  }

  std::vector<Series> all = dicom::group_series(std::move(slices));
  for (std::size_t i = 0; i < all.size(); ++i) info.series.push_back(dicom::series_line(i, all[i]));
  const std::size_t chosen = dicom::choose_series(all, series, info);
  info.series_index = static_cast<int>(chosen);
  std::vector<Slice>& chosen_slices = all[chosen].slices;
  dicom::check_consistent(chosen_slices);
  const Layout L = dicom::arrange(chosen_slices, info);
  (void)checked_voxel_count({L.dims[0], L.dims[1], L.dims[2]});

  // Output type: the stored one when nothing is rescaled, int16 when the rescaled values are integers
  // that fit, float32 otherwise.
  bool rescaled = false, integral = true, same_rescale = true;
  for (const Slice* s : L.slices) {
    rescaled = rescaled || s->slope != 1 || s->intercept != 0;
    integral = integral && s->slope == std::round(s->slope) && s->intercept == std::round(s->intercept) && std::abs(s->slope) <= 65536;
    same_rescale = same_rescale && s->slope == L.slices[0]->slope && s->intercept == L.slices[0]->intercept;
  }
  const Slice& first = *L.slices[0];
  ScalarType type = ScalarType::Float32;
  if (integral && !rescaled && !first.is_signed && first.bits_allocated == 8) type = ScalarType::UInt8;
  else if (integral && !rescaled && !first.is_signed && first.bits_allocated == 16) type = ScalarType::UInt16;
  else if (integral) type = ScalarType::Int16;

  // A window whose slices are the series' own (the slice normal is z, either way) and whose type the
  // headers settle decodes only its slices; any other is read whole and cut below.
  const auto permutation = axis_permutation(L.affine);
  const FileWindow window = file_window(choose, L.dims, permutation);
  const bool type_settled = type != ScalarType::Int16 || rescale_fits_int16(L.slices);
  if (window.in_part && type_settled) {
    const Layout W = window_layout(L, window.file_first, window.count);
    Volume window_voxels(type, W.dims, {1, 1, 1}, {0, 0, 0}, VoxelFill::Uninitialized);
    if (!dicom::fill_slices(window_voxels, W)) throw Error("a rescaled value does not fit int16 although the stored bits say it must");
    if (read)
      for (const Slice* s : W.slices) read->bytes_read += io_detail::regular_file_size(s->path);
    return place_window(std::move(window_voxels), L.affine, L.dims, *permutation, window, info);
  }
  Volume volume(type, L.dims, {1, 1, 1}, {0, 0, 0}, VoxelFill::Uninitialized);
  const bool filled = dicom::fill_slices(volume, L);
  if (!filled) {
    info.notes.push_back("rescaled values do not fit int16: the volume is float32");
    volume = Volume(ScalarType::Float32, L.dims, {1, 1, 1}, {0, 0, 0}, VoxelFill::Uninitialized);
    dicom::fill_slices(volume, L);
  }
  if (rescaled)
    info.notes.push_back(same_rescale ? "rescale slope " + num(first.slope) + " intercept " + num(first.intercept) + " applied" +
                                            (first.modality == "CT" ? ": values are Hounsfield units" : "")
                                      : std::string("rescale slope and intercept applied per slice (they differ between slices)"));
  if (first.photometric == "MONOCHROME1") info.notes.push_back("MONOCHROME1: low values are displayed bright by DICOM viewers; the values are kept");
  std::set<std::string> lossy;
  for (const Slice* s : L.slices)
    if (s->syntax->lossy) lossy.insert(s->syntax->name);
  for (const std::string& name : lossy) info.notes.push_back("pixel data compressed with lossy " + name);
  volume = keep_chosen_slices(place_volume(std::move(volume), L.affine, info), choose, window, read);
  volume.recompute_range();
  return volume;
}

}  // namespace penumbra
