// Chooses a volume loader by file extension (a folder is a DICOM series) and puts the path in front of
// any error it raises.
#include "penumbra/data/io/volume_io.h"

#include <algorithm>
#include <filesystem>

#include "penumbra/core/error.h"
#include "penumbra/data/io/text_fields.h"
#include "penumbra/data/io/volume_reduction.h"

namespace penumbra {

using io_detail::ends_with_ci;

namespace {

bool has_single_file_extension(const std::string& path) {
  for (const char* ext : {".raw", ".nrrd", ".nhdr", ".nii", ".nii.gz", ".tif", ".tiff", ".vti", ".vtk", ".vdb", ".h5", ".hdf5", ".he5"})
    if (ends_with_ci(path, ext)) return true;
  return false;
}

// A DICOM slice by its extension, or a folder (of DICOM slices) unless named like another volume file
// or holding a Zarr store.
bool is_dicom_path(const std::string& path) {
  if (ends_with_ci(path, ".dcm") || ends_with_ci(path, ".dicom")) return true;
  std::error_code ec;
  return !has_single_file_extension(path) && std::filesystem::is_directory(path, ec) && !is_zarr_store(path);
}

std::string joined(const std::vector<std::string>& paths) {
  if (paths.size() == 1) return paths[0];
  return paths.front() + " (and " + std::to_string(paths.size() - 1) + " more files)";
}

bool all_dicom(const std::vector<std::string>& paths) {
  return std::all_of(paths.begin(), paths.end(), [](const std::string& p) { return is_dicom_path(p); });
}

// An option of another format than the files' is an error, not ignored.
void check_options_fit(const std::vector<std::string>& paths, bool dicom, const VolumeLoadOptions& options) {
  const std::string& path = paths[0];
  const bool zarr = !dicom && is_zarr_store(path);
  const bool hdf5 = !dicom && is_hdf5_path(path);
  if (options.channel >= 0 && (dicom || !(zarr || hdf5 || ends_with_ci(path, ".tif") || ends_with_ci(path, ".tiff"))))
    throw Error("'channel' is for multi-channel TIFF stacks (.tif, .tiff), OME-Zarr images and HDF5 datasets");
  if (!options.dataset.empty() && !hdf5) throw Error("'dataset' is for HDF5 files (.h5, .hdf5)");
  if (options.level >= 0 && !zarr) throw Error("'level' is for OME-Zarr pyramids (a Zarr store's folder)");
  if (!options.grid.empty() && (dicom || !ends_with_ci(path, ".vdb"))) throw Error("'grid' is for OpenVDB files (.vdb)");
  if (options.raw && (dicom || !ends_with_ci(path, ".raw")))
    throw Error("'raw' (dims, type, endian) is for .raw files; this file's header gives its layout");
  if (!options.series.empty() && !dicom) throw Error("'series' is for DICOM series (a folder or .dcm files)");
}

}  // namespace

bool is_volume_file(const std::string& path) { return has_single_file_extension(path) || is_zarr_store(path) || is_dicom_path(path); }

Volume load_volume(const std::vector<std::string>& paths, const VolumeLoadOptions& options, VolumeFileInfo* info) {
  if (paths.empty()) throw Error("no volume file given");
  VolumeFileInfo local;
  VolumeFileInfo& out = info ? *info : local;
  out = VolumeFileInfo{};
  // over its budget: read reduced, in slabs (its errors name the file already)
  if (paths.size() == 1)
    if (std::optional<Volume> reduced = load_reduced_to_fit(paths[0], options, out)) return std::move(*reduced);
  return with_context(joined(paths), [&] {
    const bool dicom = all_dicom(paths);
    if (paths.size() > 1 && !dicom)
      throw Error("several files make one volume only as DICOM slices (.dcm); give other volumes one at a time");
    check_options_fit(paths, dicom, options);
    if (dicom) return load_dicom_volume(paths, options.series, &out, options.confine_to);
    const std::string& path = paths[0];
    if (is_zarr_store(path)) return load_zarr_volume(path, options.level, options.channel, &out, options.memory_budget);
    if (is_hdf5_path(path)) return load_hdf5_volume(path, options.dataset, options.channel, &out);
    // Each loader already ran recompute_range(), which rejects NaN/inf voxels and sets the range,
    // so the volume is returned as is rather than scanned twice.
    if (ends_with_ci(path, ".raw")) {
      if (!options.raw) throw Error("raw files need the 'raw' block: dims, type, endian");
      out.format = "raw";
      return load_raw_volume(path, *options.raw);
    }
    if (ends_with_ci(path, ".nrrd") || ends_with_ci(path, ".nhdr")) {
      out.format = "nrrd";
      return load_nrrd_volume(path, out, options.confine_to);
    }
    if (ends_with_ci(path, ".nii") || ends_with_ci(path, ".nii.gz")) {
      out.format = "nifti";
      return load_nifti_volume(path, out);
    }
    if (ends_with_ci(path, ".tif") || ends_with_ci(path, ".tiff")) return load_tiff_volume(path, options.channel, &out);
    if (ends_with_ci(path, ".vti")) return load_vti_volume(path, &out);
    if (ends_with_ci(path, ".vtk")) return load_legacy_vtk_volume(path, &out);
    if (ends_with_ci(path, ".vdb")) return load_vdb_volume(path, options.grid, &out);
    throw Error("unknown volume file extension (supported: .raw, .nrrd, .nhdr, .nii, .nii.gz, .tif, .tiff, .vti, .vtk, .vdb, "
                ".h5, .hdf5, .dcm, a folder of DICOM slices or a Zarr store)");
  });
}

SliceRange checked_slices(const SliceChooser& choose, const std::array<int, 3>& dims) {
  const SliceRange r = choose(dims);
  if (r.first < 0 || r.count < 1 || r.first > dims[2] - r.count)
    throw Error("slices " + std::to_string(r.first) + " to " + std::to_string(r.first + r.count - 1) + " of a volume of " +
                std::to_string(dims[2]) + " slices along z");
  return r;
}

std::string volume_format(const std::vector<std::string>& paths) {
  if (paths.empty()) return "";
  if (all_dicom(paths)) return "dicom";
  const std::string& p = paths[0];
  if (is_zarr_store(p)) return "zarr";
  if (is_hdf5_path(p)) return "hdf5";
  for (const auto& [ext, name] : {std::pair{".raw", "raw"}, {".nrrd", "nrrd"}, {".nhdr", "nrrd"}, {".nii", "nifti"}, {".nii.gz", "nifti"},
                                  {".tif", "tiff"}, {".tiff", "tiff"}, {".vti", "vti"}, {".vtk", "vtk"}, {".vdb", "vdb"}})
    if (ends_with_ci(p, ext)) return name;
  return "";
}

bool reads_slices_in_part(const std::vector<std::string>& paths, const VolumeLoadOptions& options) {
  if (!paths.empty() && all_dicom(paths)) return true;
  if (paths.size() != 1) return false;
  const std::string& p = paths[0];
  return (ends_with_ci(p, ".raw") && options.raw) || is_zarr_store(p) || is_hdf5_path(p) || ends_with_ci(p, ".nrrd") ||
         ends_with_ci(p, ".nhdr") || ends_with_ci(p, ".nii") || ends_with_ci(p, ".nii.gz") || ends_with_ci(p, ".tif") ||
         ends_with_ci(p, ".tiff") || ends_with_ci(p, ".vtk") || ends_with_ci(p, ".vti");
}

Volume load_volume_window(const std::vector<std::string>& paths, const VolumeLoadOptions& options, const SliceChooser& choose,
                          WindowRead& read) {
  read = WindowRead{};
  if (paths.empty()) throw Error("no volume file given");
  with_context(joined(paths), [&] { check_options_fit(paths, all_dicom(paths), options); });
  if (all_dicom(paths))
    return with_context(joined(paths), [&] { return load_dicom_volume(paths, options.series, nullptr, options.confine_to, &choose, &read); });
  if (reads_slices_in_part(paths, options)) {
    const std::string& path = paths[0];
    return with_context(path, [&] {
      VolumeFileInfo info;
      if (ends_with_ci(path, ".raw")) return load_raw_volume(path, *options.raw, &choose, &read);
      if (is_zarr_store(path)) return load_zarr_volume(path, options.level, options.channel, nullptr, options.memory_budget, &choose, &read);
      if (is_hdf5_path(path)) return load_hdf5_volume(path, options.dataset, options.channel, nullptr, &choose, &read);
      if (ends_with_ci(path, ".nii") || ends_with_ci(path, ".nii.gz")) return load_nifti_volume(path, &choose, &read, info);
      if (ends_with_ci(path, ".tif") || ends_with_ci(path, ".tiff")) return load_tiff_volume(path, options.channel, &info, &choose, &read);
      if (ends_with_ci(path, ".vtk")) return load_legacy_vtk_volume(path, &info, &choose, &read);
      if (ends_with_ci(path, ".vti")) return load_vti_volume(path, &info, &choose, &read);
      return load_nrrd_volume(path, &choose, &read, info, options.confine_to);
    });
  }
  Volume whole = load_volume(paths, options);
  read.whole = true;
  for (const std::string& p : paths) {
    std::error_code ec;
    const auto size = std::filesystem::is_regular_file(p, ec) ? std::filesystem::file_size(p, ec) : 0;
    read.bytes_read += ec ? 0 : static_cast<std::uint64_t>(size);
  }
  if (whole.is_bricked()) return whole;  // sparse (OpenVDB): kept whole
  const SliceRange r = with_context(joined(paths), [&] { return checked_slices(choose, whole.dims()); });
  if (r.count == whole.dims()[2]) return whole;
  Volume window = whole.window_z(r.first, r.count);
  window.recompute_range();
  return window;
}

std::optional<Volume> take_held_storage(const HeldBox* held, ScalarType type, const std::array<std::int64_t, 3>& lo,
                                        const std::array<std::int64_t, 3>& hi) {
  if (!held || !held->storage || held->storage->type() != type || held->storage->is_bricked() || held->storage->is_view()) return std::nullopt;
  const std::array<int, 3>& d = held->storage->dims();
  const std::array<int, 3> to{static_cast<int>(hi[0] - lo[0]), static_cast<int>(hi[1] - lo[1]), static_cast<int>(hi[2] - lo[2])};
  for (std::size_t a = 0; a < 3; ++a)
    if (held->hi[a] - held->lo[a] != d[a]) return std::nullopt;
  Volume taken = std::move(*held->storage);
  taken.move_voxels(to, {lo[0] - held->lo[0], lo[1] - held->lo[1], lo[2] - held->lo[2]});
  return taken;
}

Volume load_volume(const std::string& path, const VolumeLoadOptions& options, VolumeFileInfo* info) {
  return load_volume(std::vector<std::string>{path}, options, info);
}

Volume load_volume(const std::string& path, const std::optional<RawVolumeOptions>& raw) {
  VolumeLoadOptions options;
  options.raw = raw;
  return load_volume(path, options);
}

}  // namespace penumbra
