// The DICOM series loader on the staged CT series (shared/data/dicom_pancreas_ct, checked against the
// figures in PROVENANCE.md and pixel values read with pydicom), and on copies of it made here with
// GDCM: shuffled file names, a missing or duplicated slice, a second series, compressed transfer
// syntaxes, other orientations, and broken files, which must give a penumbra::Error naming the file.
#include <gtest/gtest.h>

#include <gdcm-3.0/gdcmImageChangeTransferSyntax.h>
#include <gdcm-3.0/gdcmImageReader.h>
#include <gdcm-3.0/gdcmImageWriter.h>
#include <gdcm-3.0/gdcmReader.h>
#include <gdcm-3.0/gdcmWriter.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <functional>
#include <random>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/data/io/volume_io.h"
#include "shared_data.h"
#include "test_volume_io_util.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

const std::string kUid = "1.3.6.1.4.1.14519.5.2.1.302382790855582445722435410442490497846";

std::string series_dir() { return shared_data_dir() + "/dicom_pancreas_ct"; }
std::string slice_file(int n) { return series_dir() + "/1-0" + std::to_string(n) + ".dcm"; }

// The 50 slice files, 1-045.dcm ... 1-094.dcm.
std::vector<std::string> slice_files() {
  std::vector<std::string> out;
  for (int n = 45; n <= 94; ++n) out.push_back(slice_file(n));
  return out;
}

Volume load(const std::vector<std::string>& paths, const std::string& series = "", VolumeFileInfo* info = nullptr) {
  VolumeLoadOptions options;
  options.series = series;
  return load_volume(paths, options, info);
}

// The message of the penumbra::Error that loading throws ("" and a failure when none is thrown).
std::string load_error(const std::vector<std::string>& paths, const std::string& series = "") {
  try {
    load(paths, series);
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "no penumbra::Error loading " << paths[0];
  return "";
}

#define EXPECT_MESSAGE_HAS(msg, ...)                                                            \
  for (const char* part_ : {__VA_ARGS__})                                                       \
  EXPECT_NE((msg).find(part_), std::string::npos) << "message lacks '" << part_ << "': " << (msg)

bool has_note(const VolumeFileInfo& info, const std::string& part) {
  return std::any_of(info.notes.begin(), info.notes.end(), [&](const std::string& n) { return n.find(part) != std::string::npos; });
}

void expect_same_volume(const Volume& a, const Volume& b) {
  ASSERT_EQ(a.type(), b.type());
  ASSERT_EQ(a.dims(), b.dims());
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(a.spacing()[i], b.spacing()[i]);
    EXPECT_EQ(a.origin()[i], b.origin()[i]);
  }
  EXPECT_EQ(std::memcmp(a.data(), b.data(), a.voxel_count() * scalar_size(a.type())), 0) << "voxels differ";
}

void copy(const std::string& from, const std::string& to) {
  std::filesystem::copy_file(from, to, std::filesystem::copy_options::overwrite_existing);
}

// Reads a DICOM file with GDCM, lets `edit` change its data set and writes it to `to`.
void rewrite(const std::string& from, const std::string& to, const std::function<void(gdcm::DataSet&)>& edit) {
  gdcm::Reader reader;
  reader.SetFileName(from.c_str());
  ASSERT_TRUE(reader.Read()) << from;
  edit(reader.GetFile().GetDataSet());
  gdcm::Writer writer;
  writer.SetFile(reader.GetFile());
  writer.SetFileName(to.c_str());
  ASSERT_TRUE(writer.Write()) << to;
}

// Sets a string attribute (padded to an even length with a space, or a NUL for UIDs).
void set_text(gdcm::DataSet& ds, std::uint16_t group, std::uint16_t element, gdcm::VR vr, std::string value) {
  if (value.size() % 2) value += vr == gdcm::VR::UI ? '\0' : ' ';
  gdcm::DataElement de(gdcm::Tag(group, element));
  de.SetVR(vr);
  de.SetByteValue(value.data(), static_cast<std::uint32_t>(value.size()));
  ds.Replace(de);
}

void set_us(gdcm::DataSet& ds, std::uint16_t group, std::uint16_t element, std::uint16_t value) {
  gdcm::DataElement de(gdcm::Tag(group, element));
  de.SetVR(gdcm::VR::US);
  de.SetByteValue(reinterpret_cast<const char*>(&value), 2);
  ds.Replace(de);
}

// Writes `from` with its pixel data in another transfer syntax, with GDCM's own codecs.
void change_syntax(const std::string& from, const std::string& to, gdcm::TransferSyntax::TSType syntax) {
  gdcm::ImageReader reader;
  reader.SetFileName(from.c_str());
  ASSERT_TRUE(reader.Read()) << from;
  gdcm::ImageChangeTransferSyntax change;
  change.SetTransferSyntax(syntax);
  change.SetInput(reader.GetImage());
  ASSERT_TRUE(change.Change()) << gdcm::TransferSyntax::GetTSString(syntax);
  gdcm::ImageWriter writer;
  writer.SetFile(reader.GetFile());
  writer.SetImage(change.GetOutput());
  writer.SetFileName(to.c_str());
  ASSERT_TRUE(writer.Write()) << to;
}

// The staged series loaded once (from the folder) for the tests that compare against it.
const Volume& reference() {
  static const Volume v = load({series_dir()});
  return v;
}

}  // namespace

TEST(DicomSeries, LoadsThePancreasCtAsProvenanceSays) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  VolumeFileInfo info;
  const Volume v = load({series_dir()}, "", &info);
  EXPECT_EQ(info.format, "dicom");
  EXPECT_EQ(v.type(), ScalarType::Int16);  // stored uint16, intercept -1000: Hounsfield units in int16
  EXPECT_EQ(v.dims(), (std::array<int, 3>{512, 512, 50}));
  EXPECT_FLOAT_EQ(v.spacing().x, 1.07421875f);
  EXPECT_FLOAT_EQ(v.spacing().y, 1.07421875f);
  EXPECT_FLOAT_EQ(v.spacing().z, 3.0f);
  // Voxel (0,0,0) is the lowest slice (1-094.dcm, z = 205.91), its first pixel at IPP x, y.
  EXPECT_FLOAT_EQ(v.origin().x, -275.0f);
  EXPECT_FLOAT_EQ(v.origin().y, -178.1f);
  EXPECT_FLOAT_EQ(v.origin().z, 205.91f);
  EXPECT_EQ(v.min_value(), -1000.0f);
  EXPECT_EQ(v.max_value(), 1365.0f);
  double sum = 0;
  for (std::size_t i = 0; i < v.voxel_count(); ++i) sum += v.value(i);
  EXPECT_NEAR(sum / static_cast<double>(v.voxel_count()), -700.66, 0.01);
  ASSERT_EQ(info.series.size(), 1u);
  EXPECT_MESSAGE_HAS(info.series[0], kUid.c_str(), "PANCREAS DI, iDose (3)", "CT", "50 slices", "512x512");
  EXPECT_EQ(info.series_index, 0);
  EXPECT_MESSAGE_HAS(info.orientation, "axial", "rows along +x", "columns along +y", "along +z", "LPS");
  EXPECT_TRUE(has_note(info, "intercept -1000")) << "no rescale note";
  EXPECT_TRUE(has_note(info, "Hounsfield")) << "no HU note";
  EXPECT_TRUE(has_note(info, "file order reversed")) << "no sort note";
}

// Values read with pydicom 2.3.1 (stored value - 1000): 1-070.dcm is slice 24 of the sorted volume
// (94 - 70), 1-045.dcm slice 49, 1-094.dcm slice 0; pixel (row j, column i) is voxel (i, j).
TEST(DicomSeries, VoxelsAreTheStoredValuesInHounsfieldUnits) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  const Volume& v = reference();
  EXPECT_EQ(v.value(256, 256, 24), 83.0f);
  EXPECT_EQ(v.value(300, 100, 24), -1000.0f);
  EXPECT_EQ(v.value(50, 400, 24), -942.0f);
  EXPECT_EQ(v.value(260, 300, 24), 57.0f);
  EXPECT_EQ(v.value(256, 256, 49), 119.0f);
  EXPECT_EQ(v.value(310, 200, 49), 95.0f);
  EXPECT_EQ(v.value(256, 256, 0), 423.0f);
  EXPECT_EQ(v.value(310, 200, 0), -42.0f);
  // Slice 24 lies at 1-070.dcm's ImagePositionPatient z.
  EXPECT_NEAR(v.origin().z + 24 * v.spacing().z, 277.91f, 1e-3f);
}

TEST(DicomSeries, SortsByPositionNotByFileName) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  TempDir dir;
  std::vector<std::string> files = slice_files();
  std::mt19937 rng(7);
  std::shuffle(files.begin(), files.end(), rng);
  for (std::size_t i = 0; i < files.size(); ++i) copy(files[i], dir.file("s" + std::to_string(100 + i) + ".dcm"));
  VolumeFileInfo info;
  expect_same_volume(load({dir.file("")}, "", &info), reference());
  EXPECT_TRUE(has_note(info, "not the file order"));
}

TEST(DicomSeries, FolderAndFileListAgree) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  std::vector<std::string> files = slice_files();
  expect_same_volume(load(files), reference());
  std::reverse(files.begin(), files.end());
  VolumeFileInfo info;
  expect_same_volume(load(files, "", &info), reference());
  EXPECT_TRUE(has_note(info, "sorted by ImagePositionPatient along the slice normal: the file order"));
}

TEST(DicomSeries, MissingSliceIsAnErrorNamingTheGap) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  TempDir dir;
  for (int n = 45; n <= 94; ++n)
    if (n != 70) copy(slice_file(n), dir.file("1-0" + std::to_string(n) + ".dcm"));
  const std::string msg = load_error({dir.file("")});
  EXPECT_MESSAGE_HAS(msg, "missing slice between", "1-071.dcm", "1-069.dcm", "6 mm apart", "step 3 mm");
}

TEST(DicomSeries, DuplicateSliceIsAnError) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  std::vector<std::string> files = slice_files();
  TempDir dir;
  copy(slice_file(70), dir.file("copy.dcm"));
  files.push_back(dir.file("copy.dcm"));
  const std::string msg = load_error(files);
  EXPECT_MESSAGE_HAS(msg, "same position", "1-070.dcm", "copy.dcm");
}

TEST(DicomSeries, SeriesAreGroupedAndChosenByIndexOrUid) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  TempDir dir;
  for (const std::string& f : slice_files()) copy(f, dir.file(std::filesystem::path(f).filename().string()));
  const std::string other = "1.2.826.0.1.3680043.2.1125.4242";
  for (int n = 60; n < 65; ++n)
    rewrite(slice_file(n), dir.file("other" + std::to_string(n) + ".dcm"), [&](gdcm::DataSet& ds) {
      set_text(ds, 0x0020, 0x000E, gdcm::VR::UI, other);
      set_text(ds, 0x0020, 0x0011, gdcm::VR::IS, "300");
      set_text(ds, 0x0008, 0x103E, gdcm::VR::LO, "SECOND SERIES");
    });
  VolumeFileInfo info;
  const Volume biggest = load({dir.file("")}, "", &info);
  EXPECT_EQ(biggest.dims()[2], 50);
  ASSERT_EQ(info.series.size(), 2u);
  EXPECT_MESSAGE_HAS(info.series[0], "0: ", kUid.c_str(), "50 slices");
  EXPECT_MESSAGE_HAS(info.series[1], "1: ", other.c_str(), "SECOND SERIES", "5 slices");
  EXPECT_EQ(info.series_index, 0);
  EXPECT_TRUE(has_note(info, "2 series"));
  for (const std::string& choice : {std::string("1"), other}) {
    VolumeFileInfo chosen;
    const Volume v = load({dir.file("")}, choice, &chosen);
    EXPECT_EQ(v.dims(), (std::array<int, 3>{512, 512, 5})) << choice;
    EXPECT_EQ(chosen.series_index, 1);
    EXPECT_FLOAT_EQ(v.origin().z, 205.91f + 3 * (94 - 64));  // 1-064.dcm is the lowest of the five
  }
  expect_same_volume(load({dir.file("")}, "0"), reference());
  expect_same_volume(load({dir.file("")}, kUid), reference());
  for (const char* unknown : {"2", "1.2.3"}) {
    const std::string msg = load_error({dir.file("")}, unknown);
    EXPECT_MESSAGE_HAS(msg, "no series", unknown, kUid.c_str(), other.c_str());
  }
}

TEST(DicomSeries, CompressedTransferSyntaxesGiveTheSameVoxels) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  const std::vector<std::string> originals{slice_file(69), slice_file(70), slice_file(71)};
  const Volume plain = load(originals);
  for (const auto syntax : {gdcm::TransferSyntax::RLELossless, gdcm::TransferSyntax::JPEGLosslessProcess14_1,
                            gdcm::TransferSyntax::JPEGLSLossless,
                            gdcm::TransferSyntax::ExplicitVRLittleEndian, gdcm::TransferSyntax::ExplicitVRBigEndian}) {
    SCOPED_TRACE(gdcm::TransferSyntax::GetTSString(syntax));
    TempDir dir;
    for (const std::string& f : originals) change_syntax(f, dir.file(std::filesystem::path(f).filename().string()), syntax);
    if (syntax != gdcm::TransferSyntax::ExplicitVRLittleEndian && syntax != gdcm::TransferSyntax::ExplicitVRBigEndian) {
      EXPECT_LT(std::filesystem::file_size(dir.file("1-070.dcm")), 400000u) << "not compressed";
    }
    VolumeFileInfo info;
    expect_same_volume(load({dir.file("")}, "", &info), plain);
    EXPECT_FALSE(has_note(info, "lossy"));
  }
}

// Other orientations of the same pixels: an axis-aligned series is turned so that the volume's world
// position of each pixel is its patient position; an oblique one keeps its grid.
// JPEG 2000 is refused with a message saying what to do (GDCM's JPEG 2000 decoder reads out of bounds
// on damaged codestreams, found by fuzz_dicom): never handed to the decoder.
TEST(DicomSeries, Jpeg2000IsRefusedWithAWayOut) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  TempDir dir;
  change_syntax(slice_file(70), dir.file("1-070.dcm"), gdcm::TransferSyntax::JPEG2000Lossless);
  EXPECT_MESSAGE_HAS(load_error({dir.file("1-070.dcm")}), "1-070.dcm", "JPEG 2000", "1.2.840.10008.1.2.4.90", "gdcmconv --raw");
}

TEST(DicomSeries, AxisAlignedOrientationsMapPixelsToPatientPositions) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  const Volume& axial = reference();
  struct Case {
    const char* iop;
    std::array<double, 3> r, c;
    const char* orientation;
  };
  const Case cases[] = {
      {"0\\1\\0\\0\\0\\-1", {0, 1, 0}, {0, 0, -1}, "sagittal (rows along +y, columns along -z), slices sorted by position along -x"},
      {"1\\0\\0\\0\\0\\-1", {1, 0, 0}, {0, 0, -1}, "coronal (rows along +x, columns along -z), slices sorted by position along +y"},
      {"-1\\0\\0\\0\\1\\0", {-1, 0, 0}, {0, 1, 0}, "axial (rows along -x, columns along +y), slices sorted by position along -z"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.iop);
    TempDir dir;
    const std::array<double, 3> n{c.r[1] * c.c[2] - c.r[2] * c.c[1], c.r[2] * c.c[0] - c.r[0] * c.c[2], c.r[0] * c.c[1] - c.r[1] * c.c[0]};
    const int files[] = {60, 61, 62, 63};
    std::vector<std::array<double, 3>> ipp;
    for (int f = 0; f < 4; ++f) {
      // 1-060 ... 1-063 placed 2.5 mm apart along the normal, from (10, 20, 30).
      ipp.push_back({10 + 2.5 * f * n[0], 20 + 2.5 * f * n[1], 30 + 2.5 * f * n[2]});
      const std::string pos = std::to_string(ipp.back()[0]) + "\\" + std::to_string(ipp.back()[1]) + "\\" + std::to_string(ipp.back()[2]);
      rewrite(slice_file(files[f]), dir.file("f" + std::to_string(f) + ".dcm"), [&](gdcm::DataSet& ds) {
        set_text(ds, 0x0020, 0x0037, gdcm::VR::DS, c.iop);
        set_text(ds, 0x0020, 0x0032, gdcm::VR::DS, pos);
      });
    }
    VolumeFileInfo info;
    const Volume v = load({dir.file("")}, "", &info);
    EXPECT_NE(info.orientation.find(c.orientation), std::string::npos) << info.orientation;
    for (int a = 0; a < 3; ++a) EXPECT_GT(v.spacing()[a], 0.0f);
    const double ps = 1.07421875;
    for (int f = 0; f < 4; ++f)
      for (const auto& [i, j] : {std::pair{0, 0}, std::pair{511, 0}, std::pair{0, 511}, std::pair{256, 256}, std::pair{310, 200}, std::pair{511, 511}}) {
        Vec3 p;
        for (int a = 0; a < 3; ++a) p[a] = static_cast<float>(ipp[f][static_cast<std::size_t>(a)] + i * ps * c.r[static_cast<std::size_t>(a)] + j * ps * c.c[static_cast<std::size_t>(a)]);
        const Vec3 vox = v.to_voxel(p);
        const int vi = static_cast<int>(std::lround(vox.x)), vj = static_cast<int>(std::lround(vox.y)), vk = static_cast<int>(std::lround(vox.z));
        for (int a = 0; a < 3; ++a) EXPECT_NEAR(vox[a], std::round(vox[a]), 1e-3) << "not on a voxel centre";
        ASSERT_TRUE(vi >= 0 && vj >= 0 && vk >= 0 && vi < v.dims()[0] && vj < v.dims()[1] && vk < v.dims()[2]);
        EXPECT_EQ(v.value(vi, vj, vk), axial.value(i, j, 94 - files[f])) << "file " << f << " pixel " << i << "," << j;
      }
  }
}

TEST(DicomSeries, ObliqueSeriesKeepsItsGridAndSaysSo) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  TempDir dir;
  const double s = std::sin(0.5), c = std::cos(0.5);
  const std::string iop = std::to_string(c) + "\\" + std::to_string(s) + "\\0\\" + std::to_string(-s) + "\\" + std::to_string(c) + "\\0";
  for (int f = 0; f < 3; ++f)
    rewrite(slice_file(70 - f), dir.file("o" + std::to_string(f) + ".dcm"), [&](gdcm::DataSet& ds) {
      set_text(ds, 0x0020, 0x0037, gdcm::VR::DS, iop);
      set_text(ds, 0x0020, 0x0032, gdcm::VR::DS, "5\\6\\" + std::to_string(100 + 2 * f));
    });
  VolumeFileInfo info;
  const Volume v = load({dir.file("")}, "", &info);
  EXPECT_EQ(v.dims(), (std::array<int, 3>{512, 512, 3}));
  EXPECT_FLOAT_EQ(v.spacing().z, 2.0f);
  EXPECT_FLOAT_EQ(v.origin().x, 5.0f);
  EXPECT_FLOAT_EQ(v.origin().z, 100.0f);
  EXPECT_EQ(info.orientation.rfind("oblique", 0), 0u) << info.orientation;
  EXPECT_TRUE(has_note(info, "rotation is not applied"));
  for (int f = 0; f < 3; ++f) EXPECT_EQ(v.value(310, 200, f), reference().value(310, 200, 94 - (70 - f)));
}

TEST(DicomSeries, SingleSliceTakesItsThickness) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  VolumeFileInfo info;
  const Volume v = load({slice_file(70)}, "", &info);
  EXPECT_EQ(v.dims(), (std::array<int, 3>{512, 512, 1}));
  EXPECT_FLOAT_EQ(v.spacing().z, 3.0f);
  EXPECT_FLOAT_EQ(v.origin().z, 277.91f);
  EXPECT_EQ(v.value(256, 256, 0), 83.0f);
  EXPECT_TRUE(has_note(info, "single slice"));
}

TEST(DicomSeries, NonDicomFilesInAFolderAreSkipped) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  TempDir dir;
  for (int n = 69; n <= 71; ++n) copy(slice_file(n), dir.file("1-0" + std::to_string(n) + ".dcm"));
  write_file(dir.file("README.txt"), std::string("scanned 2012\n"));
  write_file(dir.file("notes"), std::string(300, 'x'));
  VolumeFileInfo info;
  expect_same_volume(load({dir.file("")}, "", &info), load({slice_file(69), slice_file(70), slice_file(71)}));
  EXPECT_TRUE(has_note(info, "2 files in the folder are not DICOM images"));
  TempDir empty;
  write_file(empty.file("README.txt"), std::string("nothing here\n"));
  EXPECT_MESSAGE_HAS(load_error({empty.file("")}), "none of the 1 files", "DICOM");
}

// Exports from scanners and PACS nest series in subfolders with extension-less names
// (DICOM/ST000/SE001/IM0001): the folder is searched to any depth, and the series are found across it.
TEST(DicomSeries, NestedFoldersAndExtensionlessNamesAreFound) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  TempDir dir;
  const std::string first = dir.file("DICOM/ST000/SE001"), second = dir.file("DICOM/ST000/SE002");
  std::filesystem::create_directories(first);
  std::filesystem::create_directories(second);
  for (int n = 69; n <= 71; ++n) copy(slice_file(n), first + "/IM" + std::to_string(n));
  const std::string other = "1.2.826.0.1.3680043.2.1125.4243";
  for (int n = 60; n <= 61; ++n)
    rewrite(slice_file(n), second + "/IM" + std::to_string(n), [&](gdcm::DataSet& ds) { set_text(ds, 0x0020, 0x000E, gdcm::VR::UI, other); });
  write_file(dir.file("DICOM/DICOMDIR.txt"), std::string("index\n"));
  VolumeFileInfo info;
  expect_same_volume(load({dir.file("")}, "", &info), load({slice_file(69), slice_file(70), slice_file(71)}));
  ASSERT_EQ(info.series.size(), 2u);
  EXPECT_EQ(load({dir.file("")}, other).dims()[2], 2);
  rewrite(slice_file(72), first + "/IM72", [](gdcm::DataSet& ds) { set_us(ds, 0x0028, 0x0010, 256); });
  EXPECT_MESSAGE_HAS(load_error({dir.file("")}), "DICOM/ST000/SE001/IM72");  // named by its path in the folder
}

TEST(DicomSeries, BrokenFilesAreErrorsNamingTheFile) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  TempDir dir;
  const Bytes slice = read_file(slice_file(70));
  write_file(dir.file("cut_pixels.dcm"), Bytes(slice.begin(), slice.begin() + 300000));
  write_file(dir.file("cut_header.dcm"), Bytes(slice.begin(), slice.begin() + 1000));
  write_file(dir.file("garbage.dcm"), std::string("this is not a DICOM file at all, just some text that is long enough\n"));
  write_file(dir.file("empty.dcm"), std::string());
  Bytes marker(132, 0);
  std::memcpy(marker.data() + 128, "DICM", 4);
  write_file(dir.file("marker_only.dcm"), concat(marker, Bytes(64, 0xff)));
  rewrite(slice_file(70), dir.file("no_pixels.dcm"), [](gdcm::DataSet& ds) { ds.Remove(gdcm::Tag(0x7FE0, 0x0010)); });
  rewrite(slice_file(70), dir.file("zero_rows.dcm"), [](gdcm::DataSet& ds) { set_us(ds, 0x0028, 0x0010, 0); });
  rewrite(slice_file(70), dir.file("rgb.dcm"), [](gdcm::DataSet& ds) { set_us(ds, 0x0028, 0x0002, 3); });
  rewrite(slice_file(70), dir.file("bits.dcm"), [](gdcm::DataSet& ds) { set_us(ds, 0x0028, 0x0100, 12); });
  const std::pair<const char*, std::vector<const char*>> cases[] = {
      {"cut_pixels.dcm", {"(7FE0,0010)", "524288 bytes", "truncated"}},
      {"cut_header.dcm", {"truncated"}},
      {"garbage.dcm", {"not a DICOM file"}},
      {"empty.dcm", {"not a DICOM file"}},
      {"marker_only.dcm", {"DICM"}},
      {"no_pixels.dcm", {"no pixel data"}},
      {"zero_rows.dcm", {"0 rows"}},
      {"rgb.dcm", {"SamplesPerPixel is 3"}},
      {"bits.dcm", {"BitsAllocated is 12"}},
      {"missing.dcm", {"not found"}},
  };
  for (const auto& [name, parts] : cases) {
    const std::string msg = load_error({dir.file(name)});
    EXPECT_NE(msg.find(name), std::string::npos) << msg;
    for (const char* part : parts) EXPECT_NE(msg.find(part), std::string::npos) << "lacks '" << part << "': " << msg;
  }
  // In a folder among good slices, a broken slice is an error too, not skipped.
  TempDir folder;
  for (int n = 45; n <= 94; ++n) copy(slice_file(n), folder.file("1-0" + std::to_string(n) + ".dcm"));
  write_file(folder.file("1-070.dcm"), Bytes(slice.begin(), slice.begin() + 300000));
  EXPECT_MESSAGE_HAS(load_error({folder.file("")}), "1-070.dcm", "truncated");
}

TEST(DicomSeries, InconsistentSlicesNameTheFileAndTheExpectedValue) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  TempDir dir;
  rewrite(slice_file(70), dir.file("narrow.dcm"), [](gdcm::DataSet& ds) { set_us(ds, 0x0028, 0x0010, 256); });
  EXPECT_MESSAGE_HAS(load_error({slice_file(69), dir.file("narrow.dcm")}), "narrow.dcm", "Rows is 256, expected 512", "1-069.dcm");
  rewrite(slice_file(70), dir.file("spacing.dcm"), [](gdcm::DataSet& ds) { set_text(ds, 0x0028, 0x0030, gdcm::VR::DS, "0.9\\0.9"); });
  EXPECT_MESSAGE_HAS(load_error({slice_file(69), dir.file("spacing.dcm")}), "spacing.dcm", "PixelSpacing is 0.9\\0.9, expected 1.07421875\\1.07421875");
  rewrite(slice_file(70), dir.file("tilted.dcm"), [](gdcm::DataSet& ds) { set_text(ds, 0x0020, 0x0037, gdcm::VR::DS, "1\\0\\0\\0\\0\\1"); });
  EXPECT_MESSAGE_HAS(load_error({slice_file(69), dir.file("tilted.dcm")}), "tilted.dcm", "ImageOrientationPatient");
}
