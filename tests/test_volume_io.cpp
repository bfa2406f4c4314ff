// Volume loaders: the real volumes in shared/data, raw round trips in every type and byte order, small
// NRRD and NIfTI files written here, and bad input of every kind, which must give a penumbra::Error
// naming the file and the problem.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <limits>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/volume_stats.h"
#include "test_scenes.h"
#include "shared_data.h"
#include "test_volume_io_util.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

// The shared data directory: $PENUMBRA_DATA_DIR, else ../shared/data beside the checkout. Tests of real
// files are skipped (not failed) where the data is not there, e.g. on a machine with the clone alone.
const std::string kVolumeData = shared_data_dir();

// Runs load_volume, expects a penumbra::Error and returns its message ("" if none was thrown).
std::string load_error(const std::string& path, const std::optional<RawVolumeOptions>& raw = std::nullopt) {
  try {
    load_volume(path, raw);
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "no penumbra::Error loading " << path;
  return "";
}

#define EXPECT_LOAD_ERROR(path, raw, ...)                                                    \
  do {                                                                                        \
    const std::string path_ = (path);                                                         \
    EXPECT_THROW(load_volume(path_, raw), Error);                                             \
    const std::string msg_ = load_error(path_, raw);                                          \
    EXPECT_NE(msg_.find(path_), std::string::npos) << "message lacks the file name: " << msg_; \
    for (const char* part_ : {__VA_ARGS__})                                                    \
      EXPECT_NE(msg_.find(part_), std::string::npos) << "message lacks '" << part_ << "': " << msg_; \
  } while (0)

RawVolumeOptions raw_options(std::array<std::int64_t, 3> dims, ScalarType type, bool big_endian = false) {
  RawVolumeOptions o;
  o.dims = dims;
  o.type = type;
  o.big_endian = big_endian;
  return o;
}

void expect_volume(const Volume& v, std::array<int, 3> dims, ScalarType type, Vec3 spacing, float lo, float hi) {
  EXPECT_EQ(v.dims(), dims);
  EXPECT_EQ(v.type(), type);
  EXPECT_NEAR(v.spacing().x, spacing.x, 1e-4f);
  EXPECT_NEAR(v.spacing().y, spacing.y, 1e-4f);
  EXPECT_NEAR(v.spacing().z, spacing.z, 1e-4f);
  EXPECT_EQ(v.min_value(), lo);
  EXPECT_EQ(v.max_value(), hi);
}

}  // namespace

// ---------------------------------------------------------------- real volumes in shared/data

TEST(VolumeIoData, CraniumCtGzipNrrd) {
  SKIP_WITHOUT_SHARED_DATA("cranium_ct.nrrd");
  const Volume v = load_volume(kVolumeData + "/cranium_ct.nrrd");
  expect_volume(v, {256, 256, 108}, ScalarType::Int16, {0.9570312f, 0.9570312f, 1.5f}, -1024, 2986);
  EXPECT_NEAR(compute_histogram(v, 64).mean, -586, 1.0);  // PROVENANCE.md
}

TEST(VolumeIoData, ChestCtGzipNrrd) {
  SKIP_WITHOUT_SHARED_DATA("chest_ct.nrrd");
  const Volume v = load_volume(kVolumeData + "/chest_ct.nrrd");
  expect_volume(v, {256, 256, 133}, ScalarType::UInt8, {1.40625f, 1.40625f, 2.5f}, 0, 255);
  EXPECT_NEAR(compute_histogram(v, 256).mean, 7.1, 0.05);
}

TEST(VolumeIoData, ChrisT1NiftiGz) {
  SKIP_WITHOUT_SHARED_DATA("chris_t1.nii.gz");
  const Volume v = load_volume(kVolumeData + "/chris_t1.nii.gz");
  expect_volume(v, {188, 256, 190}, ScalarType::UInt8, {0.88f, 0.88f, 0.88f}, 0, 255);
  // Its sform is RAS diag(0.88) from (-83.12, -118.12, -77.12): in LPS x and y run backwards, so the
  // first stored voxel is the file's (187, 255, 0), at LPS (83.12 - 187·0.88, 118.12 - 255·0.88, -77.12).
  EXPECT_NEAR(v.origin().x, 83.12f - 187 * 0.88f, 1e-3f);
  EXPECT_NEAR(v.origin().y, 118.12f - 255 * 0.88f, 1e-3f);
  EXPECT_NEAR(v.origin().z, -77.12f, 1e-3f);
}

TEST(VolumeIoData, HeadsqDetachedNhdr) {
  SKIP_WITHOUT_SHARED_DATA("headsq.nhdr");
  const Volume v = load_volume(kVolumeData + "/headsq.nhdr");
  expect_volume(v, {64, 64, 93}, ScalarType::Int16, {3.2f, 3.2f, 1.5f}, 0, 3926);
  EXPECT_NEAR(compute_histogram(v, 16).mean, 508, 1.0);
}

TEST(VolumeIoData, NeghipDetachedNhdr) {
  SKIP_WITHOUT_SHARED_DATA("neghip.nhdr");
  const Volume v = load_volume(kVolumeData + "/neghip.nhdr");
  expect_volume(v, {66, 66, 66}, ScalarType::UInt8, {1, 1, 1}, 0, 255);
  EXPECT_NEAR(compute_histogram(v, 256).mean, 16.8, 0.05);
}

TEST(VolumeIoData, HeadsqRawMatchesNhdr) {
  SKIP_WITHOUT_SHARED_DATA("headsq.raw");
  // The same bytes through the raw loader and through teem must give the same voxels.
  RawVolumeOptions o = raw_options({64, 64, 93}, ScalarType::Int16);
  o.spacing = {3.2f, 3.2f, 1.5f};
  const Volume raw = load_volume(kVolumeData + "/headsq.raw", o);
  const Volume nrrd = load_volume(kVolumeData + "/headsq.nhdr");
  ASSERT_EQ(raw.memory_bytes(), nrrd.memory_bytes());
  EXPECT_EQ(std::memcmp(raw.data(), nrrd.data(), raw.memory_bytes()), 0);
  EXPECT_EQ(raw.max_value(), 3926);
}

// ---------------------------------------------------------------- raw

template <class T>
void raw_round_trip(const TempDir& dir, ScalarType type, bool big_endian, std::uint64_t header_bytes) {
  const std::array<std::int64_t, 3> dims{5, 3, 2};
  std::vector<T> values;
  for (int i = 0; i < 30; ++i) {
    if constexpr (std::is_same_v<T, float>) values.push_back(static_cast<float>(i) * 0.75f - 7.0f);
    else if constexpr (std::is_signed_v<T>) values.push_back(static_cast<T>(i * 997 - 15000));
    else values.push_back(static_cast<T>(i * (sizeof(T) == 1 ? 8 : 2111) + 1));
  }
  Bytes file(header_bytes, 0xAB);
  file = concat(file, to_bytes(values, big_endian));
  const std::string path = dir.file(to_string(type) + (big_endian ? "_be" : "_le") + ".raw");
  write_file(path, file);
  RawVolumeOptions o = raw_options(dims, type, big_endian);
  o.header_bytes = header_bytes;
  o.spacing = {0.5f, 1, 2};
  const Volume v = load_volume(path, o);
  ASSERT_EQ(v.type(), type);
  EXPECT_EQ(v.dims(), (std::array<int, 3>{5, 3, 2}));
  EXPECT_EQ(v.spacing().x, 0.5f);
  for (std::size_t i = 0; i < values.size(); ++i)
    ASSERT_EQ(v.value(i), static_cast<float>(values[i])) << to_string(type) << (big_endian ? " BE" : " LE") << " voxel " << i;
  EXPECT_EQ(v.min_value(), static_cast<float>(*std::min_element(values.begin(), values.end())));
  EXPECT_EQ(v.max_value(), static_cast<float>(*std::max_element(values.begin(), values.end())));
}

TEST(VolumeIoRaw, RoundTripEveryTypeAndByteOrder) {
  TempDir dir;
  for (const bool big : {false, true}) {
    raw_round_trip<std::uint8_t>(dir, ScalarType::UInt8, big, 0);
    raw_round_trip<std::int16_t>(dir, ScalarType::Int16, big, 0);
    raw_round_trip<std::uint16_t>(dir, ScalarType::UInt16, big, 0);
    raw_round_trip<float>(dir, ScalarType::Float32, big, 0);
  }
  raw_round_trip<std::int16_t>(dir, ScalarType::Int16, true, 17);  // header bytes are skipped
}

TEST(VolumeIoRaw, BigEndianBytesAreSwapped) {
  TempDir dir;
  const std::string path = dir.file("be.raw");
  write_file(path, Bytes{0x01, 0x02, 0xFF, 0xFE});
  const Volume be = load_volume(path, raw_options({2, 1, 1}, ScalarType::Int16, true));
  EXPECT_EQ(be.value(0), 0x0102);
  EXPECT_EQ(be.value(1), -2);
  const Volume le = load_volume(path, raw_options({2, 1, 1}, ScalarType::Int16, false));
  EXPECT_EQ(le.value(0), 0x0201);
  EXPECT_EQ(le.value(1), static_cast<std::int16_t>(0xFEFF));
}

TEST(VolumeIoRaw, TruncatedFileNamesBothSizes) {
  TempDir dir;
  const std::string path = dir.file("short.raw");
  write_file(path, Bytes(4 * 4 * 4 * 2 - 1, 0));
  EXPECT_LOAD_ERROR(path, raw_options({4, 4, 4}, ScalarType::Int16), "127 bytes", "128 bytes", "truncated");
}

TEST(VolumeIoRaw, OversizedFileNamesBothSizes) {
  TempDir dir;
  const std::string path = dir.file("long.raw");
  write_file(path, Bytes(4 * 4 * 4 + 1, 0));
  EXPECT_LOAD_ERROR(path, raw_options({4, 4, 4}, ScalarType::UInt8), "65 bytes", "64 bytes");
}

TEST(VolumeIoRaw, HeaderBytesLargerThanFile) {
  TempDir dir;
  const std::string path = dir.file("tiny.raw");
  write_file(path, Bytes(8, 0));
  RawVolumeOptions o = raw_options({2, 2, 2}, ScalarType::UInt8);
  o.header_bytes = std::numeric_limits<std::uint64_t>::max() - 4;  // must not wrap around
  EXPECT_LOAD_ERROR(path, o, "8 bytes");
}

TEST(VolumeIoRaw, ZeroAndNegativeDims) {
  TempDir dir;
  const std::string path = dir.file("z.raw");
  write_file(path, Bytes(16, 0));
  EXPECT_LOAD_ERROR(path, raw_options({4, 0, 4}, ScalarType::UInt8), "dimension 1 is 0");
  EXPECT_LOAD_ERROR(path, raw_options({-4, 2, 2}, ScalarType::UInt8), "dimension 0 is -4");
}

TEST(VolumeIoRaw, DimsWhoseProductOverflows) {
  TempDir dir;
  const std::string path = dir.file("huge.raw");
  write_file(path, Bytes(16, 0));
  const std::int64_t big = std::int64_t{1} << 40;
  EXPECT_LOAD_ERROR(path, raw_options({big, big, big}, ScalarType::UInt8), "absurd");
  // 2^22 cubed is 2^66: each factor fits easily, the product would wrap 64 bits.
  const std::int64_t m = std::int64_t{1} << 22;
  EXPECT_LOAD_ERROR(path, raw_options({m, m, m}, ScalarType::Float32), "absurd");
}

TEST(VolumeIoRaw, NeedsOptions) {
  TempDir dir;
  const std::string path = dir.file("a.raw");
  write_file(path, Bytes(8, 0));
  EXPECT_LOAD_ERROR(path, std::nullopt, "raw files need the 'raw' block: dims, type, endian");
}

TEST(VolumeIoRaw, NanVoxelIsRejected) {
  TempDir dir;
  const std::string path = dir.file("nan.raw");
  write_file(path, to_bytes(std::vector<float>{1, 2, std::numeric_limits<float>::quiet_NaN(), 4}));
  EXPECT_LOAD_ERROR(path, raw_options({2, 2, 1}, ScalarType::Float32), "voxel 2 is NaN");
  write_file(path, to_bytes(std::vector<float>{1, std::numeric_limits<float>::infinity(), 3, 4}));
  EXPECT_LOAD_ERROR(path, raw_options({2, 2, 1}, ScalarType::Float32), "infinite");
}

// ---------------------------------------------------------------- NRRD written here

TEST(VolumeIoNrrd, AttachedRawBigEndianWithSpaceDirections) {
  TempDir dir;
  const std::string path = dir.file("a.nrrd");
  const std::vector<std::int16_t> values{-3, 0, 7, 300, -32768, 32767, 1, 2};
  write_file(path, nrrd_file("type: short\ndimension: 3\nspace: left-posterior-superior\nsizes: 2 2 2\n"
                             "space directions: (0.5,0,0) (0,2,0) (0,0,5)\nspace origin: (10,-20,30.5)\n"
                             "endian: big\nencoding: raw\n",
                             to_bytes(values, true)));
  const Volume v = load_volume(path);
  expect_volume(v, {2, 2, 2}, ScalarType::Int16, {0.5f, 2, 5}, -32768, 32767);
  for (std::size_t i = 0; i < values.size(); ++i) EXPECT_EQ(v.value(i), values[i]);
  EXPECT_EQ(v.origin().x, 10);
  EXPECT_EQ(v.origin().y, -20);
  EXPECT_EQ(v.origin().z, 30.5f);
}

TEST(VolumeIoNrrd, GzipAndDetachedHeaders) {
  TempDir dir;
  std::vector<float> values(4 * 3 * 2);
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = static_cast<float>(i) * 0.5f - 3;
  const std::string fields = "type: float\ndimension: 3\nsizes: 4 3 2\nspacings: 1 1.25 -2\nendian: little\n";
  write_file(dir.file("g.nrrd"), nrrd_file(fields + "encoding: gzip\n", gzip(to_bytes(values))));
  write_file(dir.file("d.raw.gz"), gzip(to_bytes(values)));
  write_file(dir.file("d.nhdr"), "NRRD0004\n" + fields + "encoding: gz\ndata file: d.raw.gz\n");
  for (const char* name : {"g.nrrd", "d.nhdr"}) {
    const Volume v = load_volume(dir.file(name));
    expect_volume(v, {4, 3, 2}, ScalarType::Float32, {1, 1.25f, 2}, -3, 8.5f);
    EXPECT_EQ(v.origin().z, -2.0f) << "the negative spacing runs z backwards: the file's last slice comes first";
    for (std::size_t i = 0; i < values.size(); ++i) EXPECT_EQ(v.value((i + 12) % 24), values[i]) << name;
  }
}

TEST(VolumeIoNrrd, ConvertedTypes) {
  TempDir dir;
  const std::string dims = "dimension: 3\nsizes: 2 1 2\nendian: little\nencoding: raw\n";
  write_file(dir.file("c.nrrd"), nrrd_file("type: signed char\n" + dims, to_bytes(std::vector<std::int8_t>{-128, -1, 0, 127})));
  write_file(dir.file("i.nrrd"), nrrd_file("type: int\n" + dims, to_bytes(std::vector<std::int32_t>{-100000, 5, 0, 16777216})));
  write_file(dir.file("u.nrrd"), nrrd_file("type: uint\n" + dims, to_bytes(std::vector<std::uint32_t>{0, 1, 2, 4000000000u})));
  write_file(dir.file("d.nrrd"), nrrd_file("type: double\n" + dims, to_bytes(std::vector<double>{-1.5, 0.25, 1e10, 3})));
  const Volume c = load_volume(dir.file("c.nrrd"));
  EXPECT_EQ(c.type(), ScalarType::Int16);  // int8 widened exactly
  EXPECT_EQ(c.min_value(), -128);
  EXPECT_EQ(c.max_value(), 127);
  const Volume i = load_volume(dir.file("i.nrrd"));
  EXPECT_EQ(i.type(), ScalarType::Float32);
  EXPECT_EQ(i.value(0), -100000.0f);
  EXPECT_EQ(i.value(3), 16777216.0f);
  const Volume u = load_volume(dir.file("u.nrrd"));
  EXPECT_EQ(u.max_value(), 4e9f);
  const Volume d = load_volume(dir.file("d.nrrd"));
  EXPECT_EQ(d.type(), ScalarType::Float32);
  EXPECT_EQ(d.value(1), 0.25f);
  EXPECT_EQ(d.max_value(), 1e10f);

  write_file(dir.file("big.nrrd"), nrrd_file("type: double\n" + dims, to_bytes(std::vector<double>{1, 2, 1e300, 3})));
  EXPECT_LOAD_ERROR(dir.file("big.nrrd"), std::nullopt, "float32 range");
}

TEST(VolumeIoNrrd, LyingSizesRaw) {
  TempDir dir;
  const std::string path = dir.file("lie.nrrd");
  write_file(path, nrrd_file("type: uchar\ndimension: 3\nsizes: 8 8 8\nencoding: raw\n", Bytes(100, 1)));
  EXPECT_LOAD_ERROR(path, std::nullopt, "512 bytes", "100 bytes", "lying sizes");
}

TEST(VolumeIoNrrd, LyingSizesGzip) {
  TempDir dir;
  // Far more than the compressed bytes could ever expand to: refused before teem allocates.
  const std::string path = dir.file("lie.nrrd");
  write_file(path, nrrd_file("type: uchar\ndimension: 3\nsizes: 2000 2000 2000\nencoding: gzip\n", gzip(Bytes(512, 1))));
  EXPECT_LOAD_ERROR(path, std::nullopt, "lying sizes");
  // A plausible lie (twice the data): the stream decompresses to too little.
  write_file(path, nrrd_file("type: uchar\ndimension: 3\nsizes: 8 8 16\nencoding: gzip\n", gzip(Bytes(512, 1))));
  EXPECT_LOAD_ERROR(path, std::nullopt, "decompresses to only 512 bytes", "need 1024 bytes", "lying sizes");
}

TEST(VolumeIoNrrd, TruncatedGzip) {
  SKIP_WITHOUT_SHARED_DATA("chest_ct.nrrd");
  TempDir dir;
  Bytes bytes = read_file(kVolumeData + "/chest_ct.nrrd");
  ASSERT_GT(bytes.size(), 100000u);
  bytes.resize(bytes.size() / 2);
  const std::string path = dir.file("half.nrrd");
  write_file(path, bytes);
  EXPECT_LOAD_ERROR(path, std::nullopt, "decompresses to only 4697288 bytes", "need 8716288 bytes");

  std::vector<std::int16_t> values(16 * 16 * 16);
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = static_cast<std::int16_t>(i * 7919 % 4093);
  Bytes gz = gzip(to_bytes(values));
  gz.resize(gz.size() / 2);
  write_file(path, nrrd_file("type: short\ndimension: 3\nsizes: 16 16 16\nendian: little\nencoding: gzip\n", gz));
  EXPECT_LOAD_ERROR(path, std::nullopt, "truncated data");
  // All the data is there but the trailer is cut: teem alone would accept this.
  gz = gzip(to_bytes(values));
  gz.resize(gz.size() - 4);
  write_file(path, nrrd_file("type: short\ndimension: 3\nsizes: 16 16 16\nendian: little\nencoding: gzip\n", gz));
  EXPECT_LOAD_ERROR(path, std::nullopt, "end marker and checksum");
  // A changed byte in the middle of the stream: corrupt deflate codes or a checksum mismatch.
  gz = gzip(to_bytes(values));
  gz[gz.size() / 2] ^= 0x5A;
  write_file(path, nrrd_file("type: short\ndimension: 3\nsizes: 16 16 16\nendian: little\nencoding: gzip\n", gz));
  EXPECT_LOAD_ERROR(path, std::nullopt, "corrupt");
}

TEST(VolumeIoNrrd, AbsurdAndZeroSizes) {
  TempDir dir;
  const std::string path = dir.file("s.nrrd");
  write_file(path, nrrd_file("type: uchar\ndimension: 3\nsizes: 100000 100000 100000\nencoding: raw\n", Bytes(64, 0)));
  EXPECT_LOAD_ERROR(path, std::nullopt, "absurd");
  write_file(path, nrrd_file("type: uchar\ndimension: 3\nsizes: 4 0 4\nencoding: raw\n", Bytes(64, 0)));
  EXPECT_LOAD_ERROR(path, std::nullopt, "dimension 1 is 0");
  write_file(path, nrrd_file("type: uchar\ndimension: 3\nsizes: 4 -4 4\nencoding: raw\n", Bytes(64, 0)));
  EXPECT_LOAD_ERROR(path, std::nullopt, "dimension 1 is -4");
  write_file(path, nrrd_file("type: uchar\ndimension: 3\nsizes: 4 4 99999999999999999999999\nencoding: raw\n", Bytes(64, 0)));
  EXPECT_LOAD_ERROR(path, std::nullopt, "sizes");
}

TEST(VolumeIoNrrd, UnknownAndUnsupportedType) {
  TempDir dir;
  const std::string path = dir.file("t.nrrd");
  write_file(path, nrrd_file("type: quaternion\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n", Bytes(8, 0)));
  EXPECT_LOAD_ERROR(path, std::nullopt, "unknown NRRD type 'quaternion'");
  write_file(path, nrrd_file("type: int64\ndimension: 3\nsizes: 2 2 2\nendian: little\nencoding: raw\n", Bytes(64, 0)));
  EXPECT_LOAD_ERROR(path, std::nullopt, "not supported");
}

TEST(VolumeIoNrrd, DimensionTwo) {
  TempDir dir;
  const std::string path = dir.file("2d.nrrd");
  write_file(path, nrrd_file("type: uchar\ndimension: 2\nsizes: 4 4\nencoding: raw\n", Bytes(16, 0)));
  EXPECT_LOAD_ERROR(path, std::nullopt, "dimension is 2");
}

TEST(VolumeIoNrrd, GarbageAndEmptyFiles) {
  TempDir dir;
  write_file(dir.file("garbage.nrrd"), "this is not a volume\n\x01\x02\x03 at all");
  EXPECT_LOAD_ERROR(dir.file("garbage.nrrd"), std::nullopt, "not a NRRD file");
  write_file(dir.file("empty.nrrd"), Bytes{});
  EXPECT_LOAD_ERROR(dir.file("empty.nrrd"), std::nullopt, "empty file");
  write_file(dir.file("headonly.nrrd"), "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n");
  EXPECT_LOAD_ERROR(dir.file("headonly.nrrd"), std::nullopt, "data file");
}

TEST(VolumeIoNrrd, NanVoxel) {
  TempDir dir;
  const std::string path = dir.file("nan.nrrd");
  const float nan = std::numeric_limits<float>::quiet_NaN();
  write_file(path, nrrd_file("type: float\ndimension: 3\nsizes: 2 1 1\nendian: little\nencoding: gzip\n",
                             gzip(to_bytes(std::vector<float>{0, nan}))));
  EXPECT_LOAD_ERROR(path, std::nullopt, "voxel 1 is NaN");
}

TEST(VolumeIoNrrd, DetachedDataFileProblems) {
  TempDir dir;
  const std::string fields = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n";
  write_file(dir.file("missing.nhdr"), fields + "data file: nowhere.raw\n");
  EXPECT_LOAD_ERROR(dir.file("missing.nhdr"), std::nullopt, "nowhere.raw", "file not found");
  // teem would sprintf a %d template; anything but one plain file is refused.
  write_file(dir.file("template.nhdr"), fields + "data file: slice%03d.raw 1 2 1\n");
  EXPECT_LOAD_ERROR(dir.file("template.nhdr"), std::nullopt, "not supported");
  write_file(dir.file("short.raw"), Bytes(7, 0));
  write_file(dir.file("short.nhdr"), fields + "data file: short.raw\n");
  EXPECT_LOAD_ERROR(dir.file("short.nhdr"), std::nullopt, "8 bytes", "7 bytes");
}

TEST(VolumeIoNrrd, SkipsMembersAndByteOrderWhenReadingIntoTheVolume) {
  TempDir dir;
  const std::vector<std::int16_t> values{-3, 0, 7, 300};
  const Bytes data = to_bytes(values), junk{'j', 'u', 'n', 'k', '\n', 'x', 'y'};
  const std::string fields = "type: short\ndimension: 3\nsizes: 2 1 2\nendian: little\n";
  const auto expect_values = [&](const std::string& name) {
    const Volume v = load_volume(dir.file(name));
    ASSERT_EQ(v.voxel_count(), values.size()) << name;
    for (std::size_t i = 0; i < values.size(); ++i) EXPECT_EQ(v.value(i), values[i]) << name << " voxel " << i;
  };
  // Raw: bytes skipped before the data, or counted back from the end (-1); lines skipped first.
  write_file(dir.file("skip.nrrd"), nrrd_file(fields + "encoding: raw\nbyte skip: 3\n", concat(Bytes(3, 9), data)));
  write_file(dir.file("end.raw"), concat(junk, data));
  write_file(dir.file("end.nhdr"), "NRRD0004\n" + fields + "encoding: raw\nbyte skip: -1\ndata file: end.raw\n");
  write_file(dir.file("lines.raw"), concat(Bytes{'a', '\n', 'b', 'c', '\n'}, data));
  write_file(dir.file("lines.nhdr"), "NRRD0004\n" + fields + "encoding: raw\nline skip: 2\ndata file: lines.raw\n");
  // gzip: a byte skip counts decompressed bytes; -1 (data at the end) is left to teem; the data may span
  // several gzip members, and what follows the member that completes it is ignored.
  write_file(dir.file("gskip.nrrd"), nrrd_file(fields + "encoding: gzip\nbyte skip: 7\n", gzip(concat(junk, data))));
  write_file(dir.file("gend.nrrd"), nrrd_file(fields + "encoding: gzip\nbyte skip: -1\n", gzip(concat(junk, data))));
  const Bytes first(data.begin(), data.begin() + 3), rest(data.begin() + 3, data.end());
  write_file(dir.file("members.nrrd"), nrrd_file(fields + "encoding: gzip\n", concat(concat(gzip(first), gzip(rest)), junk)));
  for (const char* name : {"skip.nrrd", "end.nhdr", "lines.nhdr", "gskip.nrrd", "gend.nrrd", "members.nrrd"}) expect_values(name);

  // Converted types arrive through a buffer, byte-swapped there.
  write_file(dir.file("int.nrrd"), nrrd_file("type: int\ndimension: 3\nsizes: 2 1 2\nendian: big\nencoding: raw\n",
                                             to_bytes(std::vector<std::int32_t>{-5, 70000, 3, -2000000}, true)));
  const Volume i = load_volume(dir.file("int.nrrd"));
  EXPECT_EQ(i.type(), ScalarType::Float32);
  EXPECT_EQ(i.value(1), 70000.0f);
  EXPECT_EQ(i.value(3), -2000000.0f);
  // A line skip that eats into the data leaves too few bytes.
  write_file(dir.file("eaten.nrrd"), nrrd_file("type: uchar\ndimension: 3\nsizes: 2 2 1\nencoding: raw\nline skip: 1\n",
                                               Bytes{1, '\n', 3, 4}));
  EXPECT_LOAD_ERROR(dir.file("eaten.nrrd"), std::nullopt, "raw data ends after 2 bytes of the 4 bytes needed");
}

namespace {

// A "Vm...:" line of /proc/self/status, in bytes (0 where there is none).
std::uint64_t proc_status_bytes(const std::string& key) {
  std::ifstream in("/proc/self/status");
  for (std::string line; std::getline(in, line);)
    if (line.rfind(key + ":", 0) == 0) return std::stoull(line.substr(key.size() + 1)) * 1024;  // "...  123 kB"
  return 0;
}

// Resets the peak resident set size (VmHWM) to the current one (Linux 4.0+); false where refused.
bool reset_peak_rss() {
  std::ofstream out("/proc/self/clear_refs");
  out << "5";
  out.flush();
  return static_cast<bool>(out);
}

// How far loading `path` raises the peak resident memory above what was resident before.
std::uint64_t peak_growth_of_loading(const std::string& path, Volume& loaded) {
  const std::uint64_t before = proc_status_bytes("VmRSS");
  if (!reset_peak_rss() || before == 0) return 0;
  loaded = load_volume(path);
  return proc_status_bytes("VmHWM") - before;
}

}  // namespace

TEST(VolumeIoNrrd, LargeVolumesAreReadOnceIntoTheVolume) {
  if (!reset_peak_rss() || proc_status_bytes("VmHWM") == 0) GTEST_SKIP() << "no /proc/self/clear_refs or VmHWM here";
  TempDir dir;
  // 48 MiB of uint16 (a twentieth of a Visible-Woman-sized CT), big-endian so the bytes are swapped in
  // place; and 40 MiB gzip-compressed. teem's buffer plus a copy would need twice the data at peak. Both
  // are above glibc's largest mmap threshold (32 MiB), so every buffer is fresh memory that counts.
  const std::array<int, 3> dims{256, 256, 384};
  std::vector<std::uint16_t> values(static_cast<std::size_t>(dims[0]) * dims[1] * dims[2]);
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = static_cast<std::uint16_t>(i * 2654435761u >> 13);
  write_file(dir.file("big.nrrd"), nrrd_file("type: ushort\ndimension: 3\nsizes: 256 256 384\nendian: big\nencoding: raw\n",
                                             to_bytes(values, true)));
  values.resize(values.size() / 6 * 5);
  for (std::size_t i = 0; i < values.size(); ++i) values[i] = static_cast<std::uint16_t>(i / 97 % 3000);
  write_file(dir.file("big_gz.nrrd"), nrrd_file("type: ushort\ndimension: 3\nsizes: 256 256 320\nendian: little\nencoding: gzip\n",
                                                gzip(to_bytes(values))));

  for (const char* name : {"big.nrrd", "big_gz.nrrd"}) {
    Volume v;
    const std::uint64_t growth = peak_growth_of_loading(dir.file(name), v);
    ASSERT_EQ(v.dims()[2], name == std::string("big.nrrd") ? 384 : 320) << name;
    const std::size_t last = v.voxel_count() - 1;
    if (name == std::string("big.nrrd")) {
      EXPECT_EQ(v.value(last), static_cast<std::uint16_t>(last * 2654435761u >> 13));
      EXPECT_EQ(v.value(12345), static_cast<std::uint16_t>(12345 * 2654435761u >> 13));
    } else {
      EXPECT_EQ(v.value(last), values[last]);
      EXPECT_EQ(v.max_value(), 2999);
    }
    const double ratio = static_cast<double>(growth) / static_cast<double>(v.memory_bytes());
    std::printf("[ memory   ] %s: %.1f MiB of voxels, peak resident growth %.1f MiB (%.2fx)\n", name,
                static_cast<double>(v.memory_bytes()) / 1048576.0, static_cast<double>(growth) / 1048576.0, ratio);
    // The sanitizer's shadow memory and quarantine distort resident sizes; its build checks the values only.
    if (!sanitize_scale()) {
      EXPECT_LT(ratio, 1.4) << name;
    }
  }
}

// ---------------------------------------------------------------- NIfTI written here

namespace {

std::vector<std::int16_t> ramp16(std::size_t n) {
  std::vector<std::int16_t> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<std::int16_t>(static_cast<int>(i) * 37 - 500);
  return v;
}

}  // namespace

TEST(VolumeIoNifti, Int16AndGzip) {
  TempDir dir;
  NiftiSpec spec;
  spec.qoffset = {-10, 20, 5.5f};
  const auto values = ramp16(24);
  const Bytes file = nifti_file(spec, to_bytes(values));
  write_file(dir.file("a.nii"), file);
  write_file(dir.file("a.nii.gz"), gzip(file));
  for (const char* name : {"a.nii", "a.nii.gz"}) {
    const Volume v = load_volume(dir.file(name));
    expect_volume(v, {4, 3, 2}, ScalarType::Int16, {1.5f, 2, 2.5f}, -500, 23 * 37 - 500);
    for (std::size_t i = 0; i < values.size(); ++i) EXPECT_EQ(v.value(i), values[i]) << name;
    EXPECT_EQ(v.origin().x, -10);
    EXPECT_EQ(v.origin().z, 5.5f);
  }
}

TEST(VolumeIoNifti, BigEndian) {
  TempDir dir;
  NiftiSpec spec;
  spec.big_endian = true;
  spec.qoffset = {7, 8, 9};
  const auto values = ramp16(24);
  write_file(dir.file("be.nii"), nifti_file(spec, to_bytes(values, true)));
  const Volume v = load_volume(dir.file("be.nii"));
  expect_volume(v, {4, 3, 2}, ScalarType::Int16, {1.5f, 2, 2.5f}, -500, 23 * 37 - 500);
  for (std::size_t i = 0; i < values.size(); ++i) EXPECT_EQ(v.value(i), values[i]);
  EXPECT_EQ(v.origin().y, 8);
}

TEST(VolumeIoNifti, GzipTrailerIsChecked) {
  TempDir dir;
  // The voxels are all there but the gzip CRC and length are cut off: the file is still damaged.
  Bytes gz = gzip(nifti_file(NiftiSpec{}, to_bytes(ramp16(24))));
  gz.resize(gz.size() - 4);
  write_file(dir.file("t.nii.gz"), gz);
  EXPECT_LOAD_ERROR(dir.file("t.nii.gz"), std::nullopt, "corrupt compressed data");
}

TEST(VolumeIoNifti, ScalingAndConversions) {
  TempDir dir;
  NiftiSpec spec;
  spec.slope = 2;
  spec.inter = -1;
  write_file(dir.file("s.nii"), nifti_file(spec, to_bytes(ramp16(24))));
  const Volume s = load_volume(dir.file("s.nii"));
  EXPECT_EQ(s.type(), ScalarType::Float32);
  EXPECT_EQ(s.value(0), -1001.0f);
  EXPECT_EQ(s.value(1), (37 - 500) * 2.0f - 1);

  spec = NiftiSpec{};
  spec.slope = 1;  // identity scaling keeps the stored type
  spec.datatype = DT_UINT8;
  spec.bitpix = 8;
  write_file(dir.file("u8.nii"), nifti_file(spec, Bytes(24, 200)));
  EXPECT_EQ(load_volume(dir.file("u8.nii")).type(), ScalarType::UInt8);

  spec.datatype = DT_FLOAT64;
  spec.bitpix = 64;
  std::vector<double> d(24, 0.5);
  d[5] = -2.25;
  write_file(dir.file("f64.nii"), nifti_file(spec, to_bytes(d)));
  const Volume f = load_volume(dir.file("f64.nii"));
  EXPECT_EQ(f.type(), ScalarType::Float32);
  EXPECT_EQ(f.min_value(), -2.25f);

  spec.datatype = DT_COMPLEX64;
  write_file(dir.file("c.nii"), nifti_file(spec, Bytes(24 * 8, 0)));
  EXPECT_LOAD_ERROR(dir.file("c.nii"), std::nullopt, "not supported");
}

TEST(VolumeIoNifti, FourDimensions) {
  TempDir dir;
  NiftiSpec spec;
  spec.dim = {4, 4, 3, 2, 1, 1, 1, 1};  // one time point: a volume
  write_file(dir.file("t1.nii"), nifti_file(spec, to_bytes(ramp16(24))));
  EXPECT_EQ(load_volume(dir.file("t1.nii")).dims(), (std::array<int, 3>{4, 3, 2}));
  spec.dim = {4, 4, 3, 2, 3, 1, 1, 1};
  write_file(dir.file("t3.nii"), nifti_file(spec, to_bytes(ramp16(72))));
  EXPECT_LOAD_ERROR(dir.file("t3.nii"), std::nullopt, "4 dimensions", "4x3x2x3");
}

TEST(VolumeIoNifti, TwoDimensions) {
  TempDir dir;
  NiftiSpec spec;
  spec.dim = {2, 4, 3, 1, 1, 1, 1, 1};
  write_file(dir.file("2d.nii"), nifti_file(spec, to_bytes(ramp16(12))));
  EXPECT_LOAD_ERROR(dir.file("2d.nii"), std::nullopt, "2 dimensions");
}

TEST(VolumeIoNifti, BadSpacing) {
  TempDir dir;
  NiftiSpec spec;
  spec.pixdim = {1, 0, 1};
  write_file(dir.file("p.nii"), nifti_file(spec, to_bytes(ramp16(24))));
  EXPECT_LOAD_ERROR(dir.file("p.nii"), std::nullopt, "pixdim[2]");
  spec.pixdim = {1, 1, -3};  // a qform's flips are its quaternion's and qfac's (nibabel refuses this too)
  write_file(dir.file("n.nii"), nifti_file(spec, to_bytes(ramp16(24))));
  EXPECT_LOAD_ERROR(dir.file("n.nii"), std::nullopt, "pixdim[3] is -3", "with a qform");
}

TEST(VolumeIoNifti, Truncated) {
  TempDir dir;
  NiftiSpec spec;
  const Bytes file = nifti_file(spec, to_bytes(ramp16(24)));
  for (const std::size_t keep : {std::size_t{0}, std::size_t{40}, std::size_t{347}, std::size_t{352}, std::size_t{370},
                                 file.size() - 1}) {
    const std::string path = dir.file("cut" + std::to_string(keep) + ".nii");
    write_file(path, Bytes(file.begin(), file.begin() + static_cast<std::ptrdiff_t>(keep)));
    EXPECT_THROW(load_volume(path), Error) << keep;
    EXPECT_NE(load_error(path).find(path), std::string::npos);
  }
  EXPECT_LOAD_ERROR(dir.file("cut370.nii"), std::nullopt, "truncated");
  // Compressed: the stream ends early, so niftilib's read comes up short.
  std::vector<std::int16_t> many(40 * 40 * 40);
  for (std::size_t i = 0; i < many.size(); ++i) many[i] = static_cast<std::int16_t>(i * 7919 % 4093);
  spec.dim = {3, 40, 40, 40, 1, 1, 1, 1};
  Bytes gz = gzip(nifti_file(spec, to_bytes(many)));
  gz.resize(gz.size() / 2);
  write_file(dir.file("cut.nii.gz"), gz);
  EXPECT_LOAD_ERROR(dir.file("cut.nii.gz"), std::nullopt, "truncated", "voxel data");
}

TEST(VolumeIoNifti, AbsurdDimsAreRefusedBeforeAllocating) {
  TempDir dir;
  NiftiSpec spec;
  spec.dim = {3, 32767, 32767, 32767, 1, 1, 1, 1};
  spec.datatype = DT_FLOAT32;
  spec.bitpix = 32;
  write_file(dir.file("huge.nii"), nifti_file(spec, Bytes(64, 0)));
  EXPECT_LOAD_ERROR(dir.file("huge.nii"), std::nullopt, "absurd");
  spec.dim = {3, 1000, 1000, 1000, 1, 1, 1, 1};
  const Bytes lie = gzip(nifti_file(spec, Bytes(64, 0)));
  write_file(dir.file("lie.nii.gz"), lie);
  const std::string compressed = std::to_string(lie.size()) + " bytes compressed";
  EXPECT_LOAD_ERROR(dir.file("lie.nii.gz"), std::nullopt, compressed.c_str(), "4000000352 bytes", "header lies");
}

// ---------------------------------------------------------------- dispatch

TEST(VolumeIoDispatch, UnknownExtensionAndMissingFile) {
  TempDir dir;
  write_file(dir.file("v.vol"), "whatever");
  EXPECT_LOAD_ERROR(dir.file("v.vol"), std::nullopt, ".raw", ".nrrd", ".nhdr", ".nii", ".nii.gz", ".tif", ".vti", ".vtk", "DICOM");
  EXPECT_LOAD_ERROR(dir.file("absent.nrrd"), std::nullopt, "file not found");
  EXPECT_LOAD_ERROR(dir.file("absent.nii.gz"), std::nullopt, "file not found");
  EXPECT_LOAD_ERROR(dir.file("absent.raw"), raw_options({1, 1, 1}, ScalarType::UInt8), "file not found");
  std::filesystem::create_directory(dir.file("folder.nrrd"));
  EXPECT_LOAD_ERROR(dir.file("folder.nrrd"), std::nullopt, "not a regular file");
}

TEST(VolumeIoDispatch, ExtensionsAreCaseInsensitive) {
  TempDir dir;
  write_file(dir.file("UP.NRRD"), nrrd_file("type: uchar\ndimension: 3\nsizes: 2 2 1\nencoding: raw\n", Bytes{1, 2, 3, 4}));
  EXPECT_EQ(load_volume(dir.file("UP.NRRD")).max_value(), 4);
}

// A key of another format (a TIFF channel, a VDB grid, a raw layout) on a file it does not apply to is
// an error naming the file and the key, not silently ignored; a DICOM folder included.
TEST(VolumeIoDispatch, OptionsOfAnotherFormatAreErrors) {
  TempDir dir;
  write_file(dir.file("v.nrrd"), nrrd_file("type: uchar\ndimension: 3\nsizes: 2 2 1\nencoding: raw\n", Bytes{1, 2, 3, 4}));
  std::filesystem::create_directory(dir.file("slices"));  // a folder: read as a DICOM series
  for (const std::string& path : {dir.file("v.nrrd"), dir.file("slices")}) {
    SCOPED_TRACE(path);
    VolumeLoadOptions channel, grid, raw;
    channel.channel = 1;
    grid.grid = "density";
    raw.raw = raw_options({2, 2, 1}, ScalarType::UInt8);
    for (const auto& [options, key] : {std::pair{channel, "'channel'"}, std::pair{grid, "'grid'"}, std::pair{raw, "'raw'"}}) {
      std::string message;
      try {
        load_volume(std::vector<std::string>{path}, options);
      } catch (const Error& e) {
        message = e.what();
      }
      EXPECT_NE(message.find(path), std::string::npos) << message;
      EXPECT_NE(message.find(key), std::string::npos) << message;
    }
  }
  EXPECT_EQ(load_volume(dir.file("v.nrrd")).max_value(), 4);  // without them it reads
}

// ---------------------------------------------------------------- histogram

TEST(VolumeIoStats, HistogramCountsAndMean) {
  Volume v(ScalarType::UInt8, {4, 1, 1});
  v.set_value(0, 0);
  v.set_value(1, 10);
  v.set_value(2, 10);
  v.set_value(3, 255);
  const VolumeHistogram h = compute_histogram(v, 256);
  EXPECT_EQ(h.lo, 0);
  EXPECT_EQ(h.hi, 255);
  ASSERT_EQ(h.counts.size(), 256u);
  EXPECT_EQ(h.counts[0], 1u);
  EXPECT_EQ(h.counts[10], 2u);  // with 256 bins over 0..255 each integer has its own bin
  EXPECT_EQ(h.counts[255], 1u);
  EXPECT_DOUBLE_EQ(h.mean, 275.0 / 4);
  const VolumeHistogram two = compute_histogram(v, 2);
  EXPECT_EQ(two.counts[0], 3u);
  EXPECT_EQ(two.counts[1], 1u);

  Volume flat(ScalarType::Float32, {2, 2, 2});
  const VolumeHistogram f = compute_histogram(flat, 8);
  EXPECT_EQ(f.counts[0], 8u);
  EXPECT_EQ(f.lo, f.hi);
  EXPECT_THROW(compute_histogram(flat, 0), Error);
  flat.set_value(3, std::numeric_limits<float>::quiet_NaN());
  EXPECT_THROW(compute_histogram(flat, 8), Error);
}
