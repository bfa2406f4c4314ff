// A window of a volume (data/volume.h; one rank's brick, distributed/brick_reading.h) samples exactly
// as the whole grid where its samples reach, keeps the whole grid's box, and reads from files only its
// slices; the parts of a histogram over the slices add up to the whole grid's, and choose the same
// transfer function.
#include <gtest/gtest.h>

#include <cstring>
#include <filesystem>
#include <random>

#include "penumbra/core/error.h"

#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/io/zarr_writer.h"
#include "penumbra/data/procedural.h"
#include "penumbra/data/transfer_function_choice.h"
#include "penumbra/data/volume_stats.h"
#include "test_scenes.h"
#include "test_volume_io_util.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

Volume noisy_volume() {
  Volume v(ScalarType::Float32, {9, 7, 20}, {0.7f, 1.1f, 0.9f}, {-3.3f, 2.1f, -4.7f});
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.0f, 4.0f);
  for (std::size_t i = 0; i < v.voxel_count(); ++i) v.set_value(i, u(rng));
  v.recompute_range();
  return v;
}

std::uint32_t bits(float f) {
  std::uint32_t b;
  std::memcpy(&b, &f, sizeof b);
  return b;
}

}  // namespace

TEST(VolumeWindow, SamplesAndGradientsMatchTheWholeGridAwayFromItsEnds) {
  const Volume whole = noisy_volume();
  const Volume window = whole.window_z(6, 9);  // slices 6 … 14
  EXPECT_TRUE(window.is_window());
  EXPECT_EQ(window.window_first(), 6);
  EXPECT_EQ(window.whole_dims(), whole.dims());
  EXPECT_EQ(window.dims()[2], 9);
  EXPECT_EQ(window.bounds().lo, whole.bounds().lo);
  EXPECT_EQ(window.bounds().hi, whole.bounds().hi);
  EXPECT_EQ(window.min_value(), whole.min_value());
  EXPECT_EQ(window.value(2, 3, 0), whole.value(2, 3, 6));
  // every point whose trilinear cell and gradient stencil lie in the window: the same bits
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> x(-3.3f, -3.3f + 8 * 0.7f), y(2.1f, 2.1f + 6 * 1.1f), z(-4.7f + 7.1f * 0.9f, -4.7f + 12.9f * 0.9f);
  for (int i = 0; i < 2000; ++i) {
    const Vec3 p{x(rng), y(rng), z(rng)};
    ASSERT_EQ(bits(window.sample(p)), bits(whole.sample(p))) << p.x << " " << p.y << " " << p.z;
    const TrilinearCell a = window.trilinear_cell(window.to_voxel(p)), b = whole.trilinear_cell(whole.to_voxel(p));
    ASSERT_EQ(a.k + 6, b.k);
    ASSERT_EQ(bits(a.tz), bits(b.tz));
  }
  // the scene's "origin" moves the whole grid, and the window with it
  Volume moved = window;
  moved.set_origin({1, 2, 3});
  EXPECT_EQ(moved.bounds().lo, (Vec3{1, 2, 3}));
  EXPECT_FLOAT_EQ(moved.origin().z, 3 + 6 * 0.9f);
  EXPECT_THROW(whole.window_z(15, 6), Error);
  EXPECT_THROW(whole.window_z(-1, 3), Error);
}

TEST(VolumeWindow, HistogramPartsAddUpToTheWholeGridsAndChooseItsTransferFunction) {
  const Volume whole = make_procedural_volume({{"name", "hollow-sphere"}, {"size", 24}});
  const VolumeHistogram h = compute_histogram(whole, kTransferChoiceBins);
  VolumeHistogram sum = compute_histogram_part(whole, kTransferChoiceBins, h.lo, h.hi, 0, 0);
  for (const auto& [first, end] : {std::pair{0, 7}, std::pair{7, 16}, std::pair{16, 24}}) {
    const VolumeHistogram part = compute_histogram_part(whole.window_z(std::max(0, first - 2), std::min(24, end + 2) - std::max(0, first - 2)),
                                                        kTransferChoiceBins, h.lo, h.hi, first - std::max(0, first - 2),
                                                        end - std::max(0, first - 2));
    for (std::size_t b = 0; b < sum.counts.size(); ++b) sum.counts[b] += part.counts[b];
  }
  EXPECT_EQ(sum.counts, h.counts);
  EXPECT_EQ(choose_transfer_function(sum, whole.type()), choose_transfer_function(whole));
  EXPECT_THROW(compute_histogram_part(whole, 16, h.lo, h.hi, 3, 25), Error);
}

// A window is slices of the placed grid (volume_placement.h), whatever the file's order: a file whose z
// runs backwards reads the matching slices from the other end (and only them); one whose z is another
// file axis is read whole and cut.
TEST(VolumeWindow, WindowsOfReorientedFilesComeFromTheRightSlices) {
  ScratchDir dir;
  std::vector<std::int16_t> voxels(5 * 4 * 12);
  for (std::size_t i = 0; i < voxels.size(); ++i) voxels[i] = static_cast<std::int16_t>(i * 37 % 1001 - 300);
  const std::string header = "type: short\ndimension: 3\nsizes: 5 4 12\nendian: big\nspace: left-posterior-superior\nspace origin: (1,2,3)\n";
  const std::string flipped = header + "space directions: (-1,0,0) (0,1,0) (0,0,-2)\n";
  write_file(dir.file("flipped_z.nrrd"), nrrd_file(flipped + "encoding: raw\n", to_bytes(voxels, true)));
  write_file(dir.file("flipped_z_gzip.nrrd"), nrrd_file(flipped + "encoding: gzip\n", gzip(to_bytes(voxels, true))));
  write_file(dir.file("permuted.nrrd"),
             nrrd_file(header + "space directions: (0,0,2) (1,0,0) (0,1,0)\nencoding: raw\n", to_bytes(voxels, true)));
  for (const std::string file : {"flipped_z.nrrd", "flipped_z_gzip.nrrd", "permuted.nrrd"}) {
    SCOPED_TRACE(file);
    const Volume whole = load_volume(dir.file(file));
    const int slices = whole.dims()[2];
    const SliceChooser middle = [&](const std::array<int, 3>& dims) {
      EXPECT_EQ(dims, whole.dims());
      return SliceRange{1, slices - 3};  // not centred: the file's slices are 2 ... 10 of 12
    };
    WindowRead read;
    const Volume window = load_volume_window({dir.file(file)}, VolumeLoadOptions{}, middle, read);
    ASSERT_TRUE(window.is_window());
    EXPECT_EQ(window.window_first(), 1);
    EXPECT_EQ(window.bounds().lo, whole.bounds().lo);
    EXPECT_EQ(window.bounds().hi, whole.bounds().hi);
    EXPECT_FLOAT_EQ(window.origin().z, whole.origin().z + whole.spacing().z);
    const auto& d = window.dims();
    for (int k = 0; k < d[2]; ++k)
      for (int j = 0; j < d[1]; ++j)
        for (int i = 0; i < d[0]; ++i) ASSERT_EQ(window.value(i, j, k), whole.value(i, j, k + 1)) << i << " " << j << " " << k;
    EXPECT_EQ(read.whole, file == "permuted.nrrd");
    if (file == "flipped_z.nrrd") {
      EXPECT_EQ(read.bytes_read, 9u * 5 * 4 * 2);
    }
  }
}

TEST(VolumeWindow, FilesAreReadOnlyForTheChosenSlices) {
  ScratchDir dir;
  std::vector<std::int16_t> voxels(5 * 4 * 12);
  for (std::size_t i = 0; i < voxels.size(); ++i) voxels[i] = static_cast<std::int16_t>(i * 37 % 1001 - 300);
  const std::string header = "type: short\ndimension: 3\nsizes: 5 4 12\nendian: big\nspacings: 1 1 2\n";
  write_file(dir.file("raw.nrrd"), nrrd_file(header + "encoding: raw\n", to_bytes(voxels, true)));
  write_file(dir.file("gzip.nrrd"), nrrd_file(header + "encoding: gzip\n", gzip(to_bytes(voxels, true))));
  write_file(dir.file("plain.raw"), to_bytes(voxels));
  std::string ascii;
  for (const std::int16_t v : voxels) ascii += std::to_string(v) + "\n";
  write_file(dir.file("ascii.nrrd"), nrrd_file(header + "encoding: ascii\n", Bytes(ascii.begin(), ascii.end())));
  NiftiSpec nifti;
  nifti.dim = {3, 5, 4, 12, 1, 1, 1, 1};
  write_file(dir.file("plain.nii"), nifti_file(nifti, to_bytes(voxels)));
  write_file(dir.file("gzip.nii.gz"), gzip(nifti_file(nifti, to_bytes(voxels))));
  // Legacy VTK: BINARY values are big-endian; two components (the first is the volume), z reversed by its
  // negative spacing, so that the window's slices come from the file's other end.
  std::vector<std::int16_t> two_components;
  for (std::size_t k = 0; k < 12; ++k)
    for (std::size_t n = 0; n < 20; ++n) {
      two_components.push_back(voxels[(11 - k) * 20 + n]);
      two_components.push_back(static_cast<std::int16_t>(-7 * n));
    }
  const std::string vtk_header = "# vtk DataFile Version 3.0\nwindow test\n";
  const std::string vtk_grid = "DATASET STRUCTURED_POINTS\nDIMENSIONS 5 4 12\nSPACING 1 1 -2\nORIGIN 0 0 22\nPOINT_DATA 240\n";
  const Bytes vtk_values = to_bytes(two_components, true);
  Bytes binary_vtk(vtk_header.begin(), vtk_header.end());
  const std::string binary_header = "BINARY\n" + vtk_grid + "SCALARS s short 2\nLOOKUP_TABLE default\n";
  binary_vtk.insert(binary_vtk.end(), binary_header.begin(), binary_header.end());
  binary_vtk.insert(binary_vtk.end(), vtk_values.begin(), vtk_values.end());
  write_file(dir.file("binary.vtk"), binary_vtk);
  std::string ascii_vtk = vtk_header + "ASCII\n" + vtk_grid + "SCALARS s short 2\nLOOKUP_TABLE default\n";
  for (const std::int16_t v : two_components) ascii_vtk += std::to_string(v) + " ";
  write_file(dir.file("ascii.vtk"), Bytes(ascii_vtk.begin(), ascii_vtk.end()));
  const SliceChooser slices_3_to_8 = [](const std::array<int, 3>& dims) {
    EXPECT_EQ(dims[2], 12);
    return SliceRange{3, 6};
  };
  VolumeLoadOptions raw;
  raw.raw = RawVolumeOptions{{5, 4, 12}, ScalarType::Int16, false, {1, 1, 2}, 0};
  for (const std::string file : {"raw.nrrd", "gzip.nrrd", "plain.raw", "ascii.nrrd", "plain.nii", "gzip.nii.gz", "binary.vtk", "ascii.vtk"}) {
    SCOPED_TRACE(file);
    const VolumeLoadOptions options = file == "plain.raw" ? raw : VolumeLoadOptions{};  // the NRRD headers give their layout
    const Volume whole = load_volume(dir.file(file), options);
    WindowRead read;
    const Volume window = load_volume_window({dir.file(file)}, options, slices_3_to_8, read);
    ASSERT_TRUE(window.is_window());
    EXPECT_EQ(window.dims(), (std::array<int, 3>{5, 4, 6}));
    EXPECT_EQ(window.bounds().hi, whole.bounds().hi);
    for (int k = 0; k < 6; ++k)
      for (int j = 0; j < 4; ++j)
        for (int i = 0; i < 5; ++i) ASSERT_EQ(window.value(i, j, k), whole.value(i, j, k + 3));
    EXPECT_EQ(read.whole, file == "ascii.nrrd" || file == "ascii.vtk");
    if (file == "raw.nrrd" || file == "plain.raw" || file == "plain.nii") {
      EXPECT_EQ(read.bytes_read, 6u * 5 * 4 * 2);
    }
    if (file == "binary.vtk") {
      EXPECT_EQ(read.bytes_read, 6u * 5 * 4 * 2 * 2);  // both components of the chosen slices
      for (int k = 0; k < 12; ++k)  // the same voxels as the NRRD: the negative spacing reversed z back
        ASSERT_EQ(whole.value(1, 2, k), load_volume(dir.file("raw.nrrd")).value(1, 2, k));
    }
  }
  const SliceChooser too_many = [](const std::array<int, 3>&) { return SliceRange{10, 3}; };
  WindowRead read;
  try {
    (void)load_volume_window({dir.file("raw.nrrd")}, VolumeLoadOptions{}, too_many, read);
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("slices 10 to 12 of a volume of 12"), std::string::npos) << e.what();
  }
}

// In a pass (WindowPass), gzip data continues from where the last window of the file ended
// (data/io/parked_stream.h): windows read in order decompress only their own part, and windows in any
// order, of files rewritten between reads or of another file between them, are still their slices.
// Without a pass every window starts over.
TEST(VolumeWindow, GzipWindowsContinueWhereTheLastEndedAndAnyOrderIsRight) {
  ScratchDir dir;
  std::vector<std::int16_t> voxels(256 * 256 * 24);  // far more than zlib reads ahead (256 KiB)
  for (std::size_t i = 0; i < voxels.size(); ++i) voxels[i] = static_cast<std::int16_t>(i * 2654435761u % 30011 - 15000);
  const std::string header = "type: short\ndimension: 3\nsizes: 256 256 24\nendian: little\nspacings: 1 1 2\nencoding: gzip\n";
  NiftiSpec nifti;
  nifti.dim = {3, 256, 256, 24, 1, 1, 1, 1};
  write_file(dir.file("v.nrrd"), nrrd_file(header, gzip(to_bytes(voxels))));
  write_file(dir.file("v.nii.gz"), gzip(nifti_file(nifti, to_bytes(voxels))));
  write_file(dir.file("other.nii.gz"), gzip(nifti_file(nifti, to_bytes(std::vector<std::int16_t>(voxels.rbegin(), voxels.rend())))));
  const auto window = [&](const std::string& file, int first, int count, WindowRead& read) {
    return load_volume_window({dir.file(file)}, VolumeLoadOptions{}, [=](const std::array<int, 3>&) { return SliceRange{first, count}; }, read);
  };
  const auto expect_slices = [&](const Volume& w, const Volume& whole, int first) {
    for (int k = 0; k < w.dims()[2]; ++k)
      for (int j = 0; j < 256; ++j)
        for (int i = 0; i < 256; ++i) ASSERT_EQ(w.value(i, j, k), whole.value(i, j, k + first)) << i << " " << j << " " << k;
  };
  for (const std::string file : {"v.nrrd", "v.nii.gz"}) {
    SCOPED_TRACE(file);
    const Volume whole = load_volume(dir.file(file));
    WindowRead alone_read, after_read;
    (void)window(file, 0, 16, alone_read);
    (void)window(file, 16, 4, after_read);  // no pass: from the start
    EXPECT_GT(after_read.bytes_read, alone_read.bytes_read);
    const WindowPass pass;
    WindowRead first_read, next_read, fresh_read;
    (void)window(file, 0, 16, first_read);
    const Volume next = window(file, 16, 4, next_read);  // continues: reads only past slice 16
    expect_slices(next, whole, 16);
    WindowRead other_read;
    (void)window("other.nii.gz", 0, 16, other_read);  // another file's window parks its own stream, at slice 16
    const Volume again = window(file, 16, 4, fresh_read);  // not this file's (or, for the NRRD, past slice 16): starts over
    expect_slices(again, whole, 16);
    EXPECT_LT(next_read.bytes_read, fresh_read.bytes_read / 2) << "the second window decompressed from the start";
    for (const auto& [first, count] : {std::pair{19, 2}, {2, 3}, {5, 17}, {0, 1}, {23, 1}}) {
      WindowRead read;
      expect_slices(window(file, first, count, read), whole, first);
    }
  }
  // rewritten between two windows (another size): the parked stream is not the file's any more
  const WindowPass pass;
  WindowRead read;
  (void)window("v.nii.gz", 0, 4, read);
  std::vector<std::int16_t> changed(voxels.size(), 7);
  write_file(dir.file("v.nii.gz"), gzip(nifti_file(nifti, to_bytes(changed))));
  const Volume after = window("v.nii.gz", 4, 4, read);
  for (int k = 0; k < 4; ++k) ASSERT_EQ(after.value(3, 5, k), 7.0f);
}

// A Zarr store (here an OME-Zarr pyramid penumbra wrote, 8³ chunks) reads only the chunks that hold the
// chosen slices, at the level chosen, and the window is the whole level's slices.
TEST(VolumeWindow, ZarrStoresReadOnlyTheChunksOfTheChosenSlices) {
  ScratchDir dir;
  write_numbered_pyramid(dir.file("v.zarr"), {13, 10, 40});
  for (const int level : {0, 1}) {
    SCOPED_TRACE("level " + std::to_string(level));
    VolumeLoadOptions lo;
    lo.level = level;
    const Volume whole = load_volume(dir.file("v.zarr"), lo);
    const int nz = whole.dims()[2];
    for (const auto& [first, count] : std::vector<std::pair<int, int>>{{0, 5}, {9, 8}, {nz - 3, 3}, {0, nz}}) {
      SCOPED_TRACE("slices " + std::to_string(first) + " + " + std::to_string(count));
      WindowRead read;
      const Volume window = load_volume_window({dir.file("v.zarr")}, lo, [&](const std::array<int, 3>& dims) {
        EXPECT_EQ(dims, whole.dims());
        return SliceRange{first, count};
      }, read);
      EXPECT_FALSE(read.whole);
      EXPECT_EQ(window.is_window(), count < nz);
      ASSERT_EQ(window.dims(), (std::array<int, 3>{whole.dims()[0], whole.dims()[1], count}));
      EXPECT_EQ(window.bounds().lo, whole.bounds().lo);
      EXPECT_EQ(window.bounds().hi, whole.bounds().hi);
      for (int k = 0; k < count; ++k)
        for (int j = 0; j < whole.dims()[1]; ++j)
          for (int i = 0; i < whole.dims()[0]; ++i) ASSERT_EQ(window.value(i, j, k), whole.value(i, j, k + first));
      // the chunks read: those of the slices' chunk rows (2 × 2 chunks a row at level 0), each a file
      const int rows = (first + count - 1) / 8 - first / 8 + 1;
      const int chunks_a_row = ((whole.dims()[0] + 7) / 8) * ((whole.dims()[1] + 7) / 8);
      std::uint64_t row_bytes = 0, all_bytes = 0;
      for (const auto& entry : std::filesystem::recursive_directory_iterator(dir.file("v.zarr") + "/" + std::to_string(level))) {
        if (!entry.is_regular_file() || entry.path().filename().string()[0] == '.') continue;
        const int cz = std::stoi(entry.path().parent_path().parent_path().filename().string());
        all_bytes += entry.file_size();
        if (cz >= first / 8 && cz <= (first + count - 1) / 8) row_bytes += entry.file_size();
      }
      EXPECT_EQ(read.bytes_read, row_bytes) << rows << " rows of " << chunks_a_row << " chunks";
      if (count < nz && rows < (nz + 7) / 8) {
        EXPECT_LT(read.bytes_read, all_bytes);
      }
    }
  }
}
