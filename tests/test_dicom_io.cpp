// The DICOM series loader on the staged CT series (shared/data/dicom_pancreas_ct, checked against the
// figures in PROVENANCE.md and pixel values read with pydicom), and on copies of it made here with
// GDCM: shuffled file names, a missing or duplicated slice, a second series, compressed transfer
// syntaxes, other orientations, and broken files, which must give a penumbra::Error naming the file.
#include <gtest/gtest.h>

#include <gdcm-3.0/gdcmImageChangeTransferSyntax.h>
#include <gdcm-3.0/gdcmImageReader.h>
#include <gdcm-3.0/gdcmImageWriter.h>
#include <gdcm-3.0/gdcmJPEG2000Codec.h>
#include <gdcm-3.0/gdcmReader.h>
#include <gdcm-3.0/gdcmSequenceOfFragments.h>
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

// GDCM 3.0.21 leaks its copy of a JPEG-LS frame when CharLS refuses it (DamagedJpegIsAnErrorNamingTheFile
// feeds it damaged frames); that leak is GDCM's, so LeakSanitizer (the sanitize build) is told to
// ignore allocations by that codec, as fuzz_dicom does, and any other leak still fails the run.
extern "C" const char* __lsan_default_suppressions() { return "leak:gdcm::JPEGLSCodec::\n"; }

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

// Writes `from` with its pixel data in another transfer syntax, with GDCM's own codecs (or `codec`).
void change_syntax(const std::string& from, const std::string& to, gdcm::TransferSyntax::TSType syntax, gdcm::ImageCodec* codec = nullptr) {
  gdcm::ImageReader reader;
  reader.SetFileName(from.c_str());
  ASSERT_TRUE(reader.Read()) << from;
  gdcm::ImageChangeTransferSyntax change;
  change.SetTransferSyntax(syntax);
  if (codec) change.SetUserCodec(codec);
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
                            gdcm::TransferSyntax::JPEGLSLossless, gdcm::TransferSyntax::JPEG2000Lossless,
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

namespace {

// The fragments of a file's encapsulated pixel data (after the offset table).
std::vector<Bytes> pixel_fragments(const std::string& file) {
  gdcm::Reader reader;
  reader.SetFileName(file.c_str());
  std::vector<Bytes> out;
  if (!reader.Read()) {
    ADD_FAILURE() << file;
    return out;
  }
  const gdcm::SequenceOfFragments* sq = reader.GetFile().GetDataSet().GetDataElement(gdcm::Tag(0x7FE0, 0x0010)).GetSequenceOfFragments();
  if (!sq) {
    ADD_FAILURE() << file << " has no encapsulated pixel data";
    return out;
  }
  for (unsigned i = 0; i < sq->GetNumberOfFragments(); ++i) {
    const gdcm::ByteValue* bv = sq->GetFragment(i).GetByteValue();
    out.emplace_back(bv->GetPointer(), bv->GetPointer() + bv->GetLength());
  }
  return out;
}

// Writes `from` with `fragments` as its encapsulated pixel data (each padded to an even length).
void set_pixel_fragments(const std::string& from, const std::string& to, std::vector<Bytes> fragments) {
  rewrite(from, to, [&](gdcm::DataSet& ds) {
    gdcm::DataElement pixels = ds.GetDataElement(gdcm::Tag(0x7FE0, 0x0010));
    gdcm::SmartPointer<gdcm::SequenceOfFragments> sq = new gdcm::SequenceOfFragments;
    sq->GetTable() = pixels.GetSequenceOfFragments()->GetTable();
    for (Bytes& bytes : fragments) {
      if (bytes.size() % 2) bytes.push_back(0);
      gdcm::Fragment fragment;
      fragment.SetByteValue(reinterpret_cast<const char*>(bytes.data()), static_cast<std::uint32_t>(bytes.size()));
      sq->AddFragment(fragment);
    }
    pixels.SetValue(*sq);
    ds.Replace(pixels);
  });
}

// Writes `from` with its native pixel values replaced by `values` (uint8, uint16 or int16) under
// BitsAllocated = BitsStored = 8 * sizeof(T), and the given PixelRepresentation.
template <class T>
void set_native_pixels(const std::string& from, const std::string& to, const std::vector<T>& values, int representation) {
  rewrite(from, to, [&](gdcm::DataSet& ds) {
    constexpr std::uint16_t bits = 8 * sizeof(T);
    set_us(ds, 0x0028, 0x0100, bits);
    set_us(ds, 0x0028, 0x0101, bits);
    set_us(ds, 0x0028, 0x0102, bits - 1);
    set_us(ds, 0x0028, 0x0103, static_cast<std::uint16_t>(representation));
    gdcm::DataElement pixels(gdcm::Tag(0x7FE0, 0x0010));
    pixels.SetVR(sizeof(T) == 1 ? gdcm::VR::OB : gdcm::VR::OW);
    pixels.SetByteValue(reinterpret_cast<const char*>(values.data()), static_cast<std::uint32_t>(values.size() * sizeof(T)));
    ds.Replace(pixels);
  });
}

// The stored values of the staged slice `n` (12 bits in 16, unsigned).
std::vector<std::uint16_t> stored_values(int n) {
  gdcm::Reader reader;
  reader.SetFileName(slice_file(n).c_str());
  std::vector<std::uint16_t> out;
  if (!reader.Read()) {
    ADD_FAILURE() << slice_file(n);
    return out;
  }
  const gdcm::ByteValue* bv = reader.GetFile().GetDataSet().GetDataElement(gdcm::Tag(0x7FE0, 0x0010)).GetByteValue();
  out.resize(bv->GetLength() / 2);
  std::memcpy(out.data(), bv->GetPointer(), out.size() * 2);
  return out;
}

// A JP2 file around a J2K codestream: signature, file type, header (image header, colour) and codestream boxes.
Bytes jp2_file(const Bytes& codestream, int rows, int cols, int bits) {
  auto box = [](const char* type, const Bytes& content) {
    Bytes out{0, 0, 0, 0, std::uint8_t(type[0]), std::uint8_t(type[1]), std::uint8_t(type[2]), std::uint8_t(type[3])};
    const std::size_t n = content.size() + 8;
    out[0] = std::uint8_t(n >> 24), out[1] = std::uint8_t(n >> 16), out[2] = std::uint8_t(n >> 8), out[3] = std::uint8_t(n);
    return concat(out, content);
  };
  const Bytes signature{0x0D, 0x0A, 0x87, 0x0A};
  const Bytes ftyp{'j', 'p', '2', ' ', 0, 0, 0, 0, 'j', 'p', '2', ' '};
  const Bytes ihdr{0, 0, std::uint8_t(rows >> 8), std::uint8_t(rows), 0, 0, std::uint8_t(cols >> 8), std::uint8_t(cols), 0, 1,
                   std::uint8_t(bits - 1), 7, 0, 0};
  const Bytes colr{1, 0, 0, 0, 0, 0, 17};  // enumerated colour space: greyscale
  return concat(concat(concat(box("jP  ", signature), box("ftyp", ftyp)), box("jp2h", concat(box("ihdr", ihdr), box("colr", colr)))),
                box("jp2c", codestream));
}

}  // namespace

// JPEG 2000 (decoded by OpenJPEG, called directly: jpeg2000_decode.h). Slices compressed by GDCM
// decode to the voxels of the uncompressed ones: lossless only (.90), .91 as GDCM writes it by default
// (reversible, but the syntax allows loss, so it is noted), in tiles; lossy .91 within a tolerance.
TEST(DicomSeries, Jpeg2000GivesTheSameVoxels) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  const std::vector<std::string> originals{slice_file(69), slice_file(70), slice_file(71)};
  const Volume plain = load(originals);
  auto compressed = [&](const std::string& name, gdcm::TransferSyntax::TSType syntax, gdcm::ImageCodec* codec, TempDir& dir) {
    std::filesystem::create_directories(dir.file(name));
    for (const std::string& f : originals) change_syntax(f, dir.file(name + "/" + std::filesystem::path(f).filename().string()), syntax, codec);
    return dir.file(name);
  };
  TempDir dir;
  for (const auto syntax : {gdcm::TransferSyntax::JPEG2000Lossless, gdcm::TransferSyntax::JPEG2000}) {
    SCOPED_TRACE(gdcm::TransferSyntax::GetTSString(syntax));
    const std::string folder = compressed(gdcm::TransferSyntax::GetTSString(syntax), syntax, nullptr, dir);
    EXPECT_LT(std::filesystem::file_size(folder + "/1-070.dcm"), 400000u) << "not compressed";
    VolumeFileInfo info;
    expect_same_volume(load({folder}, "", &info), plain);
    EXPECT_EQ(has_note(info, "lossy JPEG 2000"), syntax == gdcm::TransferSyntax::JPEG2000);  // .91 may be lossy
  }
  {
    SCOPED_TRACE("tiles of 128x128");
    gdcm::JPEG2000Codec tiled;
    tiled.SetTileSize(128, 128);
    const std::string folder = compressed("tiled", gdcm::TransferSyntax::JPEG2000Lossless, &tiled, dir);
    const Bytes cs = pixel_fragments(folder + "/1-070.dcm").at(0);
    ASSERT_GT(cs.size(), 32u);
    EXPECT_EQ(Bytes(cs.begin() + 24, cs.begin() + 32), (Bytes{0, 0, 0, 128, 0, 0, 0, 128})) << "XTsiz, YTsiz: not in tiles";
    expect_same_volume(load({folder}), plain);
  }
  {
    SCOPED_TRACE("lossy");
    gdcm::JPEG2000Codec lossy;
    lossy.SetReversible(false);
    lossy.SetRate(0, 20);
    const std::string folder = compressed("lossy", gdcm::TransferSyntax::JPEG2000, &lossy, dir);
    EXPECT_LT(std::filesystem::file_size(folder + "/1-070.dcm"), 40000u) << "not lossy";
    VolumeFileInfo info;
    const Volume v = load({folder}, "", &info);
    EXPECT_TRUE(has_note(info, "lossy JPEG 2000"));
    ASSERT_EQ(v.type(), plain.type());
    ASSERT_EQ(v.dims(), plain.dims());
    ASSERT_EQ(v.type(), ScalarType::Int16);
    double sum = 0, largest = 0;
    for (std::size_t i = 0; i < v.voxel_count(); ++i) {
      const double d = std::abs(double(v.data_as<std::int16_t>()[i]) - double(plain.data_as<std::int16_t>()[i]));
      sum += d;
      largest = std::max(largest, d);
    }
    EXPECT_GT(largest, 0) << "no loss: not the lossy path";
    EXPECT_LT(sum / double(v.voxel_count()), 6) << "mean |difference| in HU";  // 3.2 with GDCM 3.0.21, OpenJPEG 2.5.0
    EXPECT_LT(largest, 60) << "largest |difference| in HU";                       // 29
  }
}

// JPEG 2000 of signed and 8-bit images, of a signed image whose codestream holds the stored bit
// patterns as unsigned values, of a frame split over three fragments and of a codestream wrapped in a
// JP2 file: the voxels of the uncompressed slice.
TEST(DicomSeries, Jpeg2000SignedAndEightBitImagesFragmentsAndJp2) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  TempDir dir;
  const std::vector<std::uint16_t> stored = stored_values(70);
  ASSERT_EQ(stored.size(), 512u * 512u);
  // Signed 16-bit values, -1500 to about 640.
  std::vector<std::int16_t> signed_values(stored.size());
  std::transform(stored.begin(), stored.end(), signed_values.begin(), [](std::uint16_t v) { return std::int16_t(v - 1500); });
  set_native_pixels(slice_file(70), dir.file("signed.dcm"), signed_values, 1);
  const Volume signed_plain = load({dir.file("signed.dcm")});
  ASSERT_LT(signed_plain.min_value(), -1000);  // negative values: the sign matters
  {
    SCOPED_TRACE("signed");
    change_syntax(dir.file("signed.dcm"), dir.file("signed_j2k.dcm"), gdcm::TransferSyntax::JPEG2000Lossless);
    expect_same_volume(load({dir.file("signed_j2k.dcm")}), signed_plain);
  }
  {
    // The same bit patterns as an unsigned codestream (as some encoders write signed data) under
    // PixelRepresentation 1: read as signed.
    SCOPED_TRACE("signed image, unsigned codestream");
    std::vector<std::uint16_t> patterns(signed_values.size());
    std::memcpy(patterns.data(), signed_values.data(), patterns.size() * 2);
    set_native_pixels(slice_file(70), dir.file("patterns.dcm"), patterns, 0);
    change_syntax(dir.file("patterns.dcm"), dir.file("patterns_j2k.dcm"), gdcm::TransferSyntax::JPEG2000Lossless);
    rewrite(dir.file("patterns_j2k.dcm"), dir.file("patterns_j2k_signed.dcm"), [](gdcm::DataSet& ds) { set_us(ds, 0x0028, 0x0103, 1); });
    expect_same_volume(load({dir.file("patterns_j2k_signed.dcm")}), signed_plain);
  }
  {
    SCOPED_TRACE("8-bit");
    std::vector<std::uint8_t> bytes(stored.size());
    std::transform(stored.begin(), stored.end(), bytes.begin(), [](std::uint16_t v) { return std::uint8_t(std::min(v / 8, 255)); });
    set_native_pixels(slice_file(70), dir.file("u8.dcm"), bytes, 0);
    change_syntax(dir.file("u8.dcm"), dir.file("u8_j2k.dcm"), gdcm::TransferSyntax::JPEG2000Lossless);
    const Volume u8_plain = load({dir.file("u8.dcm")});
    ASSERT_EQ(u8_plain.type(), ScalarType::Int16);  // the rescale intercept stays
    expect_same_volume(load({dir.file("u8_j2k.dcm")}), u8_plain);
  }
  const Volume plain = load({slice_file(70)});
  change_syntax(slice_file(70), dir.file("j2k.dcm"), gdcm::TransferSyntax::JPEG2000Lossless);
  const std::vector<Bytes> fragments = pixel_fragments(dir.file("j2k.dcm"));
  ASSERT_EQ(fragments.size(), 1u);
  const Bytes& cs = fragments[0];
  {
    SCOPED_TRACE("three fragments");
    const std::size_t a = 1000, b = cs.size() / 2 & ~std::size_t{1};
    set_pixel_fragments(dir.file("j2k.dcm"), dir.file("split.dcm"),
                        {Bytes(cs.begin(), cs.begin() + a), Bytes(cs.begin() + a, cs.begin() + b), Bytes(cs.begin() + b, cs.end())});
    ASSERT_EQ(pixel_fragments(dir.file("split.dcm")).size(), 3u);
    expect_same_volume(load({dir.file("split.dcm")}), plain);
  }
  {
    SCOPED_TRACE("JP2");
    set_pixel_fragments(dir.file("j2k.dcm"), dir.file("jp2.dcm"), {jp2_file(cs, 512, 512, 12)});
    expect_same_volume(load({dir.file("jp2.dcm")}), plain);
  }
}

// A damaged JPEG 2000 frame is a penumbra::Error naming the file (and what was expected), never a
// crash: a header that disagrees with the attributes is refused before OpenJPEG sees it, a truncated
// codestream is an error of OpenJPEG's (strict mode), damage elsewhere an error or other values.
TEST(DicomSeries, DamagedJpeg2000IsAnErrorNamingTheFile) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  TempDir dir;
  change_syntax(slice_file(70), dir.file("j2k.dcm"), gdcm::TransferSyntax::JPEG2000Lossless);
  const Bytes cs = pixel_fragments(dir.file("j2k.dcm")).at(0);
  ASSERT_GT(cs.size(), 1000u);
  ASSERT_EQ(cs[0], 0xFF);
  ASSERT_EQ(cs[1], 0x4F);
  auto damaged = [&](const std::string& name, const std::function<void(Bytes&)>& edit) {
    Bytes copy = cs;
    edit(copy);
    set_pixel_fragments(dir.file("j2k.dcm"), dir.file(name), {copy});
    return load_error({dir.file(name)});
  };
  const std::string truncated = damaged("truncated.dcm", [](Bytes& d) { d.resize(d.size() / 2); });
  EXPECT_MESSAGE_HAS(truncated, "truncated.dcm", "OpenJPEG failed decoding", "stream length");
  const std::string header_only = damaged("header_only.dcm", [](Bytes& d) { d.resize(200); });
  EXPECT_MESSAGE_HAS(header_only, "header_only.dcm", "OpenJPEG failed");
  const std::string magic = damaged("magic.dcm", [](Bytes& d) { d[1] = 0x00; });
  EXPECT_MESSAGE_HAS(magic, "magic.dcm", "starts with FF 00 FF 51", "expected a J2K codestream");
  const std::string width = damaged("width.dcm", [](Bytes& d) { d[10] = 0x03; });  // Xsiz 512 -> 768
  EXPECT_MESSAGE_HAS(width, "width.dcm", "JPEG 2000 codestream of 768x512 pixels", "expected 512x512");
  const std::string components = damaged("components.dcm", [](Bytes& d) { d[41] = 3; });
  EXPECT_MESSAGE_HAS(components, "components.dcm", "3 components", "expected 1");
  const std::string precision = damaged("precision.dcm", [](Bytes& d) { d[42] = 16; });
  EXPECT_MESSAGE_HAS(precision, "precision.dcm", "17 bits", "BitsAllocated, 16");
  const std::string tiles = damaged("tiles.dcm", [](Bytes& d) { d[24] = d[25] = d[26] = d[28] = d[29] = d[30] = 0, d[27] = d[31] = 4; });
  EXPECT_MESSAGE_HAS(tiles, "tiles.dcm", "16384 tiles of 4x4", "at most 4096");
  const std::string box = damaged("jp2_box.dcm", [&](Bytes& d) { d = jp2_file(cs, 512, 512, 12), d[12] = 0x7F; });
  EXPECT_MESSAGE_HAS(box, "jp2_box.dcm", "JP2 box 'ftyp' at byte 12");
  // A signed codestream with negative values under PixelRepresentation 0.
  std::vector<std::int16_t> signed_values(512 * 512);
  for (std::size_t i = 0; i < signed_values.size(); ++i) signed_values[i] = std::int16_t(int(i % 512) - 256);
  set_native_pixels(slice_file(70), dir.file("signed.dcm"), signed_values, 1);
  change_syntax(dir.file("signed.dcm"), dir.file("signed_j2k.dcm"), gdcm::TransferSyntax::JPEG2000Lossless);
  rewrite(dir.file("signed_j2k.dcm"), dir.file("unsigned.dcm"), [](gdcm::DataSet& ds) { set_us(ds, 0x0028, 0x0103, 0); });
  EXPECT_MESSAGE_HAS(load_error({dir.file("unsigned.dcm")}), "unsigned.dcm", "value -256 at row 0, column 0 is negative", "PixelRepresentation is 0");
  // Bytes changed after the SIZ marker segment (in the rest of the headers or in the coded data): an
  // Error naming the file, or a volume (JPEG 2000 decodes most damage to other values).
  std::mt19937 random(7);
  for (int k = 0; k < 40; ++k) {
    const std::string name = "random" + std::to_string(k) + ".dcm";
    Bytes copy = cs;
    for (int j = 0; j < 1 + k % 4; ++j)
      copy[std::uniform_int_distribution<std::size_t>(45, k % 2 ? copy.size() - 1 : 300)(random)] ^= std::uint8_t(1 + random() % 255);
    set_pixel_fragments(dir.file("j2k.dcm"), dir.file(name), {copy});
    try {
      load({dir.file(name)});
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
    }
  }
}

// A damaged JPEG Lossless or JPEG-LS frame is a penumbra::Error naming the file, never a crash or a
// leak (the sanitizer build checks both): a precision GDCM has no decoder for (above 16 bits it
// dereferenced a null decoder) and a codestream cut short (GDCM suspended IJG's decoder and never
// released it) are refused before GDCM sees them; damage elsewhere is GDCM's error or other values.
TEST(DicomSeries, DamagedJpegIsAnErrorNamingTheFile) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  for (const auto syntax : {gdcm::TransferSyntax::JPEGLosslessProcess14_1, gdcm::TransferSyntax::JPEGLSLossless}) {
    SCOPED_TRACE(gdcm::TransferSyntax::GetTSString(syntax));
    TempDir dir;
    change_syntax(slice_file(70), dir.file("jpeg.dcm"), syntax);
    const Bytes cs = pixel_fragments(dir.file("jpeg.dcm")).at(0);
    ASSERT_GT(cs.size(), 1000u);
    ASSERT_EQ(cs[0], 0xFF);
    ASSERT_EQ(cs[1], 0xD8);
    std::size_t sof = 2;  // the frame header: SOF3 (JPEG Lossless) or SOF55 (JPEG-LS)
    while (sof + 4 < cs.size() && !(cs[sof + 1] == 0xC3 || cs[sof + 1] == 0xF7)) sof += 2 + (cs[sof + 2] << 8 | cs[sof + 3]);
    ASSERT_LT(sof + 10, cs.size());
    auto damaged = [&](const std::string& name, const std::function<void(Bytes&)>& edit) {
      Bytes copy = cs;
      edit(copy);
      set_pixel_fragments(dir.file("jpeg.dcm"), dir.file(name), {copy});
      return load_error({dir.file(name)});
    };
    for (const int bits : {17, 112}) {
      const std::string name = "precision" + std::to_string(bits) + ".dcm", samples = "JPEG samples of " + std::to_string(bits) + " bits";
      EXPECT_MESSAGE_HAS(damaged(name, [&](Bytes& d) { d[sof + 4] = std::uint8_t(bits); }), name.c_str(), samples.c_str(),
                         "at most BitsAllocated 16");
    }
    for (const std::size_t keep : {cs.size() / 2, std::size_t(300), cs.size() - 2}) {
      const std::string name = "truncated" + std::to_string(keep) + ".dcm";
      EXPECT_MESSAGE_HAS(damaged(name, [&](Bytes& d) { d.resize(keep); }), name.c_str(), "does not end with an EOI marker", "truncated");
    }
    const std::string width = damaged("width.dcm", [&](Bytes& d) { d[sof + 7] = 0x03; });  // 512 -> 768 samples per line
    EXPECT_MESSAGE_HAS(width, "width.dcm", "JPEG codestream of 768x512 pixels", "expected 512x512");
    // Bytes changed after the frame header (in the tables or the coded data): an Error naming the file,
    // or a volume.
    std::mt19937 random(11);
    for (int k = 0; k < 40; ++k) {
      const std::string name = "random" + std::to_string(k) + ".dcm";
      Bytes copy = cs;
      for (int j = 0; j < 1 + k % 4; ++j)
        copy[std::uniform_int_distribution<std::size_t>(sof + 10, k % 2 ? copy.size() - 3 : sof + 100)(random)] ^= std::uint8_t(1 + random() % 255);
      set_pixel_fragments(dir.file("jpeg.dcm"), dir.file(name), {copy});
      try {
        load({dir.file(name)});
      } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(name), std::string::npos) << e.what();
      }
    }
  }
}

// Other orientations of the same pixels: an axis-aligned series is turned so that the volume's world
// position of each pixel is its patient position; an oblique one keeps its grid.
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

// An oblique series (rows turned 0.5 rad about z) is resampled onto the patient axes at its smallest
// spacing, covering its world box, and says so; a sample at a pixel's patient position lies within the
// pixels around it.
TEST(DicomSeries, ObliqueSeriesIsResampledOntoPatientAxes) {
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
  const double ps = 1.07421875, side = 511 * ps;
  for (int a = 0; a < 3; ++a) EXPECT_NEAR(v.spacing()[a], ps, 1e-6);
  // The rotated square spans side·(cos + sin) along x and y; the slices 4 mm along z.
  EXPECT_EQ(v.dims()[0], static_cast<int>(std::floor(side * (c + s) / ps + 1e-6)) + 1);
  EXPECT_EQ(v.dims()[2], static_cast<int>(std::floor(4 / ps)) + 1);
  EXPECT_NEAR(v.origin().x, 5 - side * s, 1e-3);
  EXPECT_NEAR(v.origin().y, 6, 1e-3);
  EXPECT_NEAR(v.origin().z, 100, 1e-4);
  EXPECT_EQ(info.orientation.rfind("oblique", 0), 0u) << info.orientation;
  EXPECT_TRUE(has_note(info, "resampled trilinearly onto an axis-aligned grid"));
  ASSERT_TRUE(info.affine.has_value());
  EXPECT_NEAR(info.affine->linear[1][0], s * ps, 1e-6);
  const Volume& axial = reference();
  for (const auto& [i, j] : {std::pair{100, 100}, std::pair{256, 256}, std::pair{310, 200}, std::pair{400, 300}}) {
    const Vec3 p{static_cast<float>(5 + ps * (i * c - j * s)), static_cast<float>(6 + ps * (i * s + j * c)), 100.0f};
    float lo = 1e30f, hi = -1e30f;
    for (int dj = -2; dj <= 2; ++dj)
      for (int di = -2; di <= 2; ++di) {
        const float x = axial.value(i + di, j + dj, 94 - 70);
        lo = std::min(lo, x), hi = std::max(hi, x);
      }
    const float got = v.sample(p);
    EXPECT_TRUE(got >= lo - 0.5f && got <= hi + 0.5f) << "pixel " << i << "," << j << ": " << got << " outside " << lo << " .. " << hi;
  }
}

// A tilted gantry: axial slices whose positions also move along y (1 mm per 2 mm slice) make a sheared
// grid, resampled onto the patient axes: a slice's pixel lands at its own patient position.
TEST(DicomSeries, GantryTiltIsAShearedGridResampled) {
  SKIP_WITHOUT_SHARED_DATA("dicom_pancreas_ct/1-045.dcm");
  TempDir dir;
  for (int f = 0; f < 4; ++f)
    rewrite(slice_file(70 - f), dir.file("t" + std::to_string(f) + ".dcm"), [&](gdcm::DataSet& ds) {
      set_text(ds, 0x0020, 0x0037, gdcm::VR::DS, "1\\0\\0\\0\\1\\0");
      set_text(ds, 0x0020, 0x0032, gdcm::VR::DS, "5\\" + std::to_string(6 + f) + "\\" + std::to_string(100 + 2 * f));
    });
  VolumeFileInfo info;
  const Volume v = load({dir.file("")}, "", &info);
  EXPECT_TRUE(has_note(info, "within the slice plane over the series (gantry tilt?): the grid is sheared"));
  EXPECT_TRUE(has_note(info, "resampled trilinearly"));
  ASSERT_TRUE(info.affine.has_value());
  EXPECT_NEAR(info.affine->linear[1][2], 1.0, 1e-9);
  EXPECT_NEAR(info.affine->linear[2][2], 2.0, 1e-9);
  const double ps = 1.07421875;
  EXPECT_NEAR(v.origin().y, 6, 1e-4);
  EXPECT_NEAR(v.bounds().hi.y, 6 + 511 * ps + 3, 1.5 * ps);
  // On slice 0 (z = 100, a grid plane of the resampled volume) the grid's points fall between pixels
  // only along y, and 3 mm up the y shift is 1.5 mm: the samples stay within the pixels around.
  for (const auto& [i, j] : {std::pair{100, 100}, std::pair{256, 256}, std::pair{400, 300}}) {
    const Vec3 p{static_cast<float>(5 + ps * i), static_cast<float>(6 + ps * j), 100.0f};
    float lo = 1e30f, hi = -1e30f;
    for (int dj = -1; dj <= 1; ++dj) {
      const float x = reference().value(i, j + dj, 94 - 70);
      lo = std::min(lo, x), hi = std::max(hi, x);
    }
    const float got = v.sample(p);
    EXPECT_TRUE(got >= lo - 0.5f && got <= hi + 0.5f) << "pixel " << i << "," << j << ": " << got << " outside " << lo << " .. " << hi;
  }
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
