// Volume files: raw (dimensions, type and endianness given by the caller), NRRD (attached and detached
// headers, raw and gzip encodings), NIfTI-1 (.nii, .nii.gz), DICOM series (a folder or a list of
// slices, through GDCM), multi-page TIFF stacks (through libtiff, with ImageJ metadata) and VTK image
// data (XML .vti and legacy .vtk STRUCTURED_POINTS), OpenVDB grids (sparse). Every loader checks what it reads: truncated data,
// lying headers, unsupported types, zero or absurd dimensions and NaN voxels give an Error naming the
// file and what was expected.
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "penumbra/data/volume.h"

namespace penumbra {

struct RawVolumeOptions {
  std::array<std::int64_t, 3> dims{0, 0, 0};
  ScalarType type = ScalarType::UInt8;
  bool big_endian = false;
  Vec3 spacing{1, 1, 1};
  std::uint64_t header_bytes = 0;  // bytes to skip at the start of the file
};

// A file's index-to-world transform in the world frame LPS (see volume_placement.h): the world position of
// voxel (i, j, k) is linear · (i, j, k) + offset; column a of `linear` is the world step of index a.
struct Affine {
  std::array<std::array<double, 3>, 3> linear{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};  // linear[row][column]
  std::array<double, 3> offset{0, 0, 0};
  static Affine diagonal(const std::array<double, 3>& steps, const std::array<double, 3>& origin);
  std::array<double, 3> column(int a) const { return {linear[0][a], linear[1][a], linear[2][a]}; }
  std::array<double, 3> apply(const std::array<double, 3>& index) const;
  std::string str() const;  // "[a b c t; d e f u; g h i v]"
};

// What a reader found beside the voxels, for `penumbra info` and for the user to know what was done.
struct VolumeFileInfo {
  std::string format;                // "raw", "nrrd", "nifti", "dicom", "tiff", "vti", "vtk", "vdb"
  std::string orientation;           // how the file's axes became the volume's x, y, z ("" = as stored)
  std::optional<Affine> affine;      // the file's index-to-world transform (LPS), when the format has one
  std::vector<std::string> series;   // DICOM: one line per series in the input (UID, description, slices)
  int series_index = -1;             // DICOM: the series loaded (index into `series`)
  int channels = 1;                  // TIFF: channels in the file
  int channel = 0;                   // TIFF: the channel loaded
  std::vector<std::string> notes;    // what else the reader did (rescale applied, default spacing, ...)
};

// What the caller chooses beyond the file name.
struct VolumeLoadOptions {
  std::optional<RawVolumeOptions> raw;  // .raw files: their layout
  std::string series;                   // DICOM: SeriesInstanceUID or index ("" = the series with the most slices)
  int channel = -1;                     // multi-channel TIFF or OME-Zarr image: channel from 0 (-1 = channel 0)
  int level = -1;                       // OME-Zarr pyramid: level from 0, the finest (-1 = the finest that fits, zarr_loader.cpp)
  // Bytes the volume may hold (volume_held_bytes: its voxels and macrocells): an OME-Zarr pyramid opens
  // at the finest level that fits (unless `level` is given), an NRRD, HDF5 or raw file over it reduced
  // (volume_reduction.h). 0: no budget; a pyramid then opens at the finest level that fits a quarter of
  // this machine's memory.
  std::uint64_t memory_budget = 0;
  std::string grid;                     // OpenVDB: grid name or index ("" = "density", else the first scalar grid)
  std::string dataset;                  // HDF5: the dataset's path in the file ("" = its only dataset of 3+ axes)
  // A canonical folder that every file the volume's files name must lie inside: an NRRD header's data
  // file, a DICOM folder's slices (links resolved). "" confines nothing; the viewer sets its data root.
  std::string confine_to;
};

// Reading part of a volume (one rank's brick, distributed/brick_reading.h): slices [first, first +
// count) along z of the file's grid.
struct SliceRange {
  int first = 0, count = 0;
};
// Chooses the slices from the whole grid's dimensions, known once the header is read; throws Error when
// it cannot (more bricks than slices).
using SliceChooser = std::function<SliceRange(const std::array<int, 3>& dims)>;
// What reading part of a volume cost.
struct WindowRead {
  std::uint64_t bytes_read = 0;  // from the file(s)
  std::uint64_t bytes_reused = 0;  // voxels copied from a box held before (load_zarr_box), not read
  bool whole = false;            // read whole and then cut: a format or encoding that cannot seek to a slice
};
// The chosen slices, checked against the grid (Error naming them when they do not lie in it).
SliceRange checked_slices(const SliceChooser& choose, const std::array<int, 3>& dims);

// Readers of formats with a world frame place their voxels by it (volume_placement.h) and record the
// affine in `info`.
Volume load_raw_volume(const std::string& path, const RawVolumeOptions& options);
Volume load_nrrd_volume(const std::string& path, VolumeFileInfo& info, const std::string& confine_to = "");  // .nrrd or .nhdr
// Only the chosen slices of a raw file or of NRRD raw data (seeking past the others), or of NRRD gzip
// data (decompressing and dropping the slices before them, stopping after the last); other NRRD
// encodings are read whole and cut. The result is a window of the whole grid (Volume::is_window) unless
// the slices are all of them; its value range is its own.
Volume load_raw_volume(const std::string& path, const RawVolumeOptions& options, const SliceChooser* choose, WindowRead* read);
// A window of a file whose z is reversed reads the matching slices from the other end; one whose z comes
// from another file axis is read whole and cut.
Volume load_nrrd_volume(const std::string& path, const SliceChooser* choose, WindowRead* read, VolumeFileInfo& info,
                        const std::string& confine_to = "");
Volume load_nifti_volume(const std::string& path, VolumeFileInfo& info);  // .nii or .nii.gz
// Only the chosen slices when the file's z stays the volume's z (reversed or not): an uncompressed file
// seeks to them, a gzip one decompresses up to them and stops after the last; otherwise read whole and cut.
Volume load_nifti_volume(const std::string& path, const SliceChooser* choose, WindowRead* read, VolumeFileInfo& info);

// DICOM (dicom_loader.cpp): `paths` is one folder (every DICOM file in it and its subfolders) or a list
// of slice files. Slices are grouped by SeriesInstanceUID; `series` picks one (see VolumeLoadOptions).
// `choose`: only the chosen slices' pixel data is decoded (every file's header is still read, to group,
// sort and check the series; `read` says the chosen slices' file sizes) when the slice normal is the
// volume's z and the headers settle the voxel type (no rescale that could leave int16); otherwise the
// series is read whole and cut.
Volume load_dicom_volume(const std::vector<std::string>& paths, const std::string& series, VolumeFileInfo* info,
                         const std::string& confine_to = "", const SliceChooser* choose = nullptr, WindowRead* read = nullptr);
// Multi-page TIFF (tiff_loader.cpp): 8/16/32-bit integer or float pages of one size; ImageJ hyperstacks
// are de-interleaved and `channel` (-1 = 0) chosen. `choose`: only the pages of the chosen slices are
// decoded (`read` says their stored bytes; every page's directory is still read, to check the stack).
Volume load_tiff_volume(const std::string& path, int channel, VolumeFileInfo* info, const SliceChooser* choose = nullptr,
                        WindowRead* read = nullptr);
// VTK image data (vti_loader.cpp, vtk_legacy_loader.cpp): XML ImageData (.vti: ascii, base64 or appended raw, zlib or
// not) and legacy STRUCTURED_POINTS (.vtk, ASCII or BINARY).
Volume load_vti_volume(const std::string& path, VolumeFileInfo* info);
// `choose`: a binary array (base64 or appended, zlib or not) yields only the chosen slices' bytes (raw
// appended data seeks to them; zlib blocks outside them are not decompressed; base64 before them is
// stepped over); an ASCII array is read whole and cut.
Volume load_vti_volume(const std::string& path, VolumeFileInfo* info, const SliceChooser* choose, WindowRead* read);
Volume load_legacy_vtk_volume(const std::string& path, VolumeFileInfo* info);
// `choose`: a BINARY file reads only the chosen slices' values (seeking to them); an ASCII one is read whole and cut.
Volume load_legacy_vtk_volume(const std::string& path, VolumeFileInfo* info, const SliceChooser* choose, WindowRead* read);
// OpenVDB (vdb_loader.cpp): one float or double grid, kept sparse as a bricked volume.
Volume load_vdb_volume(const std::string& path, const std::string& grid, VolumeFileInfo* info);

// Zarr v2 and v3 (zarr_loader.cpp, zarr_array.h): a folder holding one array (.zarray, zarr.json) or an
// OME-Zarr 0.4 or 0.5 image (.zattrs, or zarr.json's attributes.ome, with "multiscales"), of which one level (`level`; -1: the finest whose volume_held_bytes fit `memory_budget`,
// or with no budget (0) a quarter of the machine's memory) and one channel (-1: 0) are read, chunk by
// chunk; missing chunks hold the fill value.
// With `choose`, only the chosen slices are read, from the chunks that hold them (a window of the whole
// grid, as load_raw_volume's; a level whose z scale is negative is read whole and cut).
bool is_zarr_store(const std::string& path);
Volume load_zarr_volume(const std::string& path, int level, int channel, VolumeFileInfo* info, std::uint64_t memory_budget = 0,
                        const SliceChooser* choose = nullptr, WindowRead* read = nullptr);
// A box of one level of an OME-Zarr pyramid: voxels [lo, hi) along x, y, z (index space of that level),
// placed where they lie (its origin the box's first voxel), only the chunks that hold it read; the value
// range its own, opacities referring to the finest level's voxel. What a refined view reads
// (render/view_refinement.h). Error for a box outside the level or a level whose scale reverses an axis.
// `held`: a box of the same level already in memory (the one a refined view held before): the chunks
// whose part of the new box lies inside it are copied from it instead of read (`read->bytes_reused`).
// With `storage`, the held box gives its own voxels up to the new box when it has the new box's type:
// its storage grows or shrinks to the new box and they are moved in place (Volume::move_voxels), and
// only the rest is read, so that a box that moves never holds two boxes at once (`storage` is then left
// empty).
struct HeldBox {
  std::array<std::int64_t, 3> lo{}, hi{};  // its voxels [lo, hi) of the level
  const Volume* voxels = nullptr;          // dense, of the level's type
  Volume* storage = nullptr;               // the held box's voxels (the same as `voxels`), to be taken over
};
// The storage of a new box [lo, hi) of `type` taken from held->storage as HeldBox says, the voxels both
// boxes hold already in place; nothing when there is no storage to take or its type differs.
std::optional<Volume> take_held_storage(const HeldBox* held, ScalarType type, const std::array<std::int64_t, 3>& lo,
                                        const std::array<std::int64_t, 3>& hi);
Volume load_zarr_box(const std::string& path, int level, int channel, const std::array<std::int64_t, 3>& lo,
                     const std::array<std::int64_t, 3>& hi, WindowRead* read = nullptr, const HeldBox* held = nullptr);
// The grid of one level of a pyramid (0 the finest), as its reader places it.
struct LevelGrid {
  std::array<int, 3> dims{};
  Vec3 spacing{1, 1, 1}, origin{0, 0, 0};
  ScalarType type = ScalarType::UInt8;
};
// The grids of an OME-Zarr pyramid's levels as load_zarr_volume places them; empty for a store that is no
// pyramid or one whose scales reverse an axis.
std::vector<LevelGrid> zarr_level_grids(const std::string& path);
// What a pyramid's level must fit without a memory budget: a quarter of this machine's memory.
std::uint64_t default_pyramid_budget();
// HDF5 (hdf5_loader.cpp; .h5, .hdf5, .he5): one numeric dataset (`dataset`, "" = the only one of three or
// more axes), z y x last, a leading channel axis chosen by `channel`; the filters libhdf5 decodes.
bool is_hdf5_path(const std::string& path);
// `choose`: only the chosen slices along z (a hyperslab; `read` says the stored bytes of their chunks).
Volume load_hdf5_volume(const std::string& path, const std::string& dataset, int channel, VolumeFileInfo* info,
                        const SliceChooser* choose = nullptr, WindowRead* read = nullptr);
// Whether the path names a volume: a volume extension (.raw, .nrrd, .nhdr, .nii, .nii.gz, .dcm, .tif,
// .tiff, .vti, .vtk, .vdb, .h5, .hdf5, .he5; any case) or a folder (a Zarr store, else a DICOM series).
bool is_volume_file(const std::string& path);

// Chooses the loader by extension (.raw needs `raw`; a folder or .dcm files are a DICOM series). The
// returned volume has its value range computed; `info`, when given, says what the reader found.
Volume load_volume(const std::vector<std::string>& paths, const VolumeLoadOptions& options, VolumeFileInfo* info = nullptr);
Volume load_volume(const std::string& path, const VolumeLoadOptions& options, VolumeFileInfo* info = nullptr);
Volume load_volume(const std::string& path, const std::optional<RawVolumeOptions>& raw = std::nullopt);
// The format the files are read as, by their names: "dicom", "zarr", "hdf5", "raw", "nrrd", "nifti",
// "tiff", "vti", "vtk", "vdb" ("" for none of these).
std::string volume_format(const std::vector<std::string>& paths);
// Whether load_volume_window reads only the chosen slices of these files: a DICOM series, one raw (with its
// layout), NRRD, NIfTI, TIFF, VTK image data (.vti, legacy .vtk) or HDF5 file or Zarr store (by name; a layout
// that cannot be, such as an NRRD whose z is another file axis or ASCII VTK values, is still read whole,
// which `read.whole` says).
bool reads_slices_in_part(const std::vector<std::string>& paths, const VolumeLoadOptions& options);
// A pass over files a window of slices at a time (`penumbra convert`, a read reduced under a budget): while
// one is open, a window of gzip data (NRRD, NIfTI) continues from where the same file's last window ended
// when that is not past it, instead of decompressing everything before it again (parked_stream.h); the
// streams are closed when the last pass ends.
class WindowPass {
public:
  WindowPass();
  ~WindowPass();
  WindowPass(const WindowPass&) = delete;
  WindowPass& operator=(const WindowPass&) = delete;
};
// load_volume of the chosen slices only: the formats above read just those; OpenVDB (sparse) is read whole,
// which `read.whole` says.
Volume load_volume_window(const std::vector<std::string>& paths, const VolumeLoadOptions& options, const SliceChooser& choose,
                          WindowRead& read);

}  // namespace penumbra
