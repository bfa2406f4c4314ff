// TIFF stacks: the two staged microscopy TIFFs (values checked against tifffile), small stacks written
// here with libtiff in every supported sample type, layout and compression, ImageJ hyperstacks, and bad
// input, which must give a penumbra::Error naming the file and the problem.
#include <gtest/gtest.h>
#include <tiffio.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>
#include <tuple>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/data/io/volume_io.h"
#include "shared_data.h"
#include "test_volume_io_util.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

Volume load_tiff(const std::string& path, int channel = -1, VolumeFileInfo* info = nullptr) {
  VolumeLoadOptions options;
  options.channel = channel;
  return load_volume(path, options, info);
}

// The message of the Error load_volume throws, checked to name the file and each of `parts`.
void expect_error(const std::string& path, int channel, std::initializer_list<const char*> parts) {
  try {
    load_tiff(path, channel);
    ADD_FAILURE() << "no penumbra::Error loading " << path;
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << "message lacks the file name: " << msg;
    for (const char* part : parts) EXPECT_NE(msg.find(part), std::string::npos) << "message lacks '" << part << "': " << msg;
  }
}

double mean(const Volume& v) {
  double sum = 0;
  for (std::size_t i = 0; i < v.voxel_count(); ++i) sum += v.value(i);
  return sum / static_cast<double>(v.voxel_count());
}

// One page to write: its samples (x fastest, then samples of a pixel) and how to store them.
struct Page {
  std::uint32_t width = 4, height = 3;
  std::uint16_t bits = 8, samples = 1, format = SAMPLEFORMAT_UINT;
  std::uint16_t compression = COMPRESSION_NONE, planar = PLANARCONFIG_CONTIG;
  std::uint32_t tile = 0;           // tile width and height (0: strips)
  std::uint32_t rows_per_strip = 2;
  std::string description;
  float xres = 0, yres = 0;
  std::uint16_t res_unit = RESUNIT_NONE;
  Bytes data;                       // width*height*samples values of bits/8 bytes, native order, contiguous
};

template <class T>
Bytes values_bytes(const std::vector<T>& v) {
  return to_bytes(v);
}

// Writes the pages with libtiff ("b": big-endian file, else little-endian).
void write_tiff(const std::string& path, const std::vector<Page>& pages, bool big_endian = false) {
  TIFF* tif = TIFFOpen(path.c_str(), big_endian ? "wb" : "wl");
  ASSERT_NE(tif, nullptr);
  for (const Page& p : pages) {
    TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, p.width);
    TIFFSetField(tif, TIFFTAG_IMAGELENGTH, p.height);
    TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, p.bits);
    TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, p.samples);
    TIFFSetField(tif, TIFFTAG_SAMPLEFORMAT, p.format);
    TIFFSetField(tif, TIFFTAG_COMPRESSION, p.compression);
    TIFFSetField(tif, TIFFTAG_PLANARCONFIG, p.planar);
    TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, p.samples == 3 ? PHOTOMETRIC_RGB : PHOTOMETRIC_MINISBLACK);
    if (p.compression == COMPRESSION_LZW && p.format != SAMPLEFORMAT_IEEEFP) TIFFSetField(tif, TIFFTAG_PREDICTOR, PREDICTOR_HORIZONTAL);
    if (!p.description.empty()) TIFFSetField(tif, TIFFTAG_IMAGEDESCRIPTION, p.description.c_str());
    if (p.xres > 0) TIFFSetField(tif, TIFFTAG_XRESOLUTION, p.xres);
    if (p.yres > 0) TIFFSetField(tif, TIFFTAG_YRESOLUTION, p.yres);
    if (p.xres > 0 || p.yres > 0) TIFFSetField(tif, TIFFTAG_RESOLUTIONUNIT, p.res_unit);
    TIFFSetField(tif, TIFFTAG_SUBFILETYPE, FILETYPE_PAGE);
    const std::size_t bytes = p.bits / 8u;
    const std::size_t planes = p.planar == PLANARCONFIG_SEPARATE ? p.samples : 1;
    const std::size_t step = p.planar == PLANARCONFIG_SEPARATE ? 1 : p.samples;
    // The samples of plane `s` (all of them when contiguous) of the rectangle at (x0, y0).
    const auto block = [&](std::size_t s, std::uint32_t x0, std::uint32_t y0, std::uint32_t w, std::uint32_t h) {
      Bytes out(std::size_t{w} * h * step * bytes, 0);
      for (std::uint32_t y = 0; y < h && y0 + y < p.height; ++y)
        for (std::uint32_t x = 0; x < w && x0 + x < p.width; ++x)
          for (std::size_t c = 0; c < step; ++c) {
            const std::size_t sample = planes > 1 ? s : c;
            const std::size_t src = ((std::size_t{y0 + y} * p.width + x0 + x) * p.samples + sample) * bytes;
            std::memcpy(&out[((std::size_t{y} * w + x) * step + c) * bytes], &p.data[src], bytes);
          }
      return out;
    };
    if (p.tile) {
      TIFFSetField(tif, TIFFTAG_TILEWIDTH, p.tile);
      TIFFSetField(tif, TIFFTAG_TILELENGTH, p.tile);
      for (std::size_t s = 0; s < planes; ++s)
        for (std::uint32_t y = 0; y < p.height; y += p.tile)
          for (std::uint32_t x = 0; x < p.width; x += p.tile) {
            Bytes t = block(s, x, y, p.tile, p.tile);
            ASSERT_GE(TIFFWriteTile(tif, t.data(), x, y, 0, static_cast<std::uint16_t>(s)), 0);
          }
    } else {
      TIFFSetField(tif, TIFFTAG_ROWSPERSTRIP, p.rows_per_strip);
      std::uint32_t strip = 0;
      for (std::size_t s = 0; s < planes; ++s)
        for (std::uint32_t y = 0; y < p.height; y += p.rows_per_strip) {
          const std::uint32_t rows = std::min(p.rows_per_strip, p.height - y);
          Bytes b = block(s, 0, y, p.width, rows);
          ASSERT_GE(TIFFWriteEncodedStrip(tif, strip++, b.data(), static_cast<tmsize_t>(b.size())), 0);
        }
    }
    ASSERT_TRUE(TIFFWriteDirectory(tif));
  }
  TIFFClose(tif);
}

// A page of `values` (width*height*samples of them).
template <class T>
Page page_of(std::uint32_t w, std::uint32_t h, const std::vector<T>& values, std::uint16_t format, std::uint16_t samples = 1) {
  Page p;
  p.width = w, p.height = h, p.samples = samples, p.format = format;
  p.bits = static_cast<std::uint16_t>(sizeof(T) * 8);
  p.data = values_bytes(values);
  return p;
}

template <class T>
std::vector<T> ramp(std::size_t n, double start, double step) {
  std::vector<T> v(n);
  for (std::size_t i = 0; i < n; ++i) v[i] = static_cast<T>(start + step * static_cast<double>(i));
  return v;
}


// Every truncation of `bytes` and a flipped byte at every position must load or give an Error naming
// the file; counts which. (libFuzzer does this at length in fuzz/fuzz_tiff.cpp; this runs in every build.)
void sweep(const TempDir& dir, const std::string& name, const Bytes& bytes, int& loaded, int& refused) {
  int count = 0;
  const auto attempt = [&](const Bytes& b, const std::string& what) {
    // A fresh name each time, removed after: rewriting one file in place is slow on ext4 with discard.
    const std::string path = dir.file(std::to_string(count++) + "_" + name);
    write_file(path, b);
    try {
      const Volume v = load_volume(path, VolumeLoadOptions{});
      EXPECT_LE(v.min_value(), v.max_value());
      ++loaded;
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
      ++refused;
    } catch (const std::exception& e) {
      ADD_FAILURE() << name << " " << what << ": non-penumbra exception: " << e.what();
    }
    std::filesystem::remove(path);
  };
  const std::size_t step = std::max<std::size_t>(1, bytes.size() / 300);
  for (std::size_t n = 0; n < bytes.size(); n += step) attempt(Bytes(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(n)), "cut at " + std::to_string(n));
  for (std::size_t i = 0; i < bytes.size(); i += step) {
    Bytes b = bytes;
    b[i] = static_cast<std::uint8_t>(b[i] ^ (i % 3 == 0 ? 0xff : i % 3 == 1 ? 0x01 : 0x80));
    attempt(b, "byte " + std::to_string(i) + " flipped");
  }
}
}  // namespace

TEST(TiffStaged, ArabidopsisEmbryoPlainStack) {
  SKIP_WITHOUT_SHARED_DATA("arabidopsis_embryo.tif");
  VolumeFileInfo info;
  const Volume v = load_tiff(shared_data_dir() + "/arabidopsis_embryo.tif", -1, &info);
  EXPECT_EQ(v.dims(), (std::array<int, 3>{109, 112, 106}));
  EXPECT_EQ(v.type(), ScalarType::UInt8);
  EXPECT_EQ(v.spacing(), (Vec3{1, 1, 1}));
  EXPECT_EQ(v.min_value(), 0);
  EXPECT_EQ(v.max_value(), 255);
  EXPECT_NEAR(mean(v), 11.4772, 1e-3);
  // tifffile: a[z, y, x]; the first row of a page is y = 0.
  EXPECT_EQ(v.value(0, 0, 0), 4);
  EXPECT_EQ(v.value(70, 60, 50), 23);
  EXPECT_EQ(v.value(54, 56, 53), 32);
  EXPECT_EQ(v.value(108, 111, 105), 9);
  EXPECT_EQ(info.format, "tiff");
  EXPECT_EQ(info.channels, 1);
  EXPECT_TRUE(has_note(info, "no voxel size in the file: spacing 1"));
}

TEST(TiffStaged, NucleusHyperstackBothChannels) {
  SKIP_WITHOUT_SHARED_DATA("nucleus_conf_wf.tif");
  const std::string path = shared_data_dir() + "/nucleus_conf_wf.tif";
  VolumeFileInfo info;
  const Volume c0 = load_tiff(path, -1, &info);
  EXPECT_EQ(c0.dims(), (std::array<int, 3>{133, 130, 45}));
  EXPECT_EQ(c0.type(), ScalarType::UInt16);
  // From XResolution (1.953591 px/micron) and ImageJ spacing, not from the Info block (0.2559).
  EXPECT_NEAR(c0.spacing().x, 1 / 1.953591, 1e-6);
  EXPECT_NEAR(c0.spacing().y, 1 / 1.953591, 1e-6);
  EXPECT_NEAR(c0.spacing().z, 0.4994126, 1e-6);
  EXPECT_EQ(c0.min_value(), 0);
  EXPECT_EQ(c0.max_value(), 61711);
  EXPECT_NEAR(mean(c0), 448.1429, 1e-3);
  EXPECT_EQ(c0.value(30, 20, 10), 5);
  EXPECT_EQ(c0.value(66, 65, 22), 24282);
  EXPECT_EQ(c0.value(132, 129, 44), 11);
  EXPECT_EQ(info.channels, 2);
  EXPECT_EQ(info.channel, 0);
  EXPECT_TRUE(has_note(info, "ImageJ hyperstack: 2 channels x 45 slices, channel 0 loaded"));
  EXPECT_TRUE(has_note(info, "voxel size 0.511878 x 0.511878 x 0.499413 \u00b5m"));

  const Volume c1 = load_tiff(path, 1, &info);
  EXPECT_EQ(c1.dims(), c0.dims());
  EXPECT_EQ(c1.min_value(), 608);
  EXPECT_EQ(c1.max_value(), 7480);
  EXPECT_NEAR(mean(c1), 965.1539, 1e-3);
  EXPECT_EQ(c1.value(0, 0, 0), 671);
  EXPECT_EQ(c1.value(30, 20, 10), 665);
  EXPECT_EQ(c1.value(66, 65, 22), 5052);
  EXPECT_EQ(c1.value(132, 129, 44), 656);
  EXPECT_EQ(info.channel, 1);

  expect_error(path, 2, {"channel 2 is out of range", "2 channels"});
}

TEST(TiffWrite, Uint16BigEndianLzwRoundTrip) {
  TempDir dir;
  const auto a = ramp<std::uint16_t>(30, 100, 2000), b = ramp<std::uint16_t>(30, 65535, -1000);
  Page p1 = page_of(6, 5, a, SAMPLEFORMAT_UINT), p2 = page_of(6, 5, b, SAMPLEFORMAT_UINT);
  p1.compression = p2.compression = COMPRESSION_LZW;
  write_tiff(dir.file("s.tif"), {p1, p2}, true);
  VolumeFileInfo info;
  const Volume v = load_tiff(dir.file("s.tif"), -1, &info);
  ASSERT_EQ(v.dims(), (std::array<int, 3>{6, 5, 2}));
  EXPECT_EQ(v.type(), ScalarType::UInt16);
  for (std::size_t i = 0; i < 30; ++i) {
    EXPECT_EQ(v.value(i), a[i]);
    EXPECT_EQ(v.value(30 + i), b[i]);
  }
  EXPECT_EQ(info.channels, 1);
}

TEST(TiffWrite, Float32TiledDeflateRoundTrip) {
  TempDir dir;
  // 20x18 with 16x16 tiles: partial tiles on the right and bottom.
  const auto a = ramp<float>(360, -3.5, 0.25), b = ramp<float>(360, 1e6, -17.125);
  Page p1 = page_of(20, 18, a, SAMPLEFORMAT_IEEEFP), p2 = page_of(20, 18, b, SAMPLEFORMAT_IEEEFP);
  p1.tile = p2.tile = 16;
  p1.compression = p2.compression = COMPRESSION_ADOBE_DEFLATE;
  write_tiff(dir.file("f.tiff"), {p1, p2, p1});
  const Volume v = load_tiff(dir.file("f.tiff"));
  ASSERT_EQ(v.dims(), (std::array<int, 3>{20, 18, 3}));
  EXPECT_EQ(v.type(), ScalarType::Float32);
  for (std::size_t i = 0; i < 360; ++i) {
    EXPECT_EQ(v.value(i), a[i]);
    EXPECT_EQ(v.value(360 + i), b[i]);
    EXPECT_EQ(v.value(720 + i), a[i]);
  }
}

TEST(TiffWrite, SignedAndWideIntegerTypes) {
  TempDir dir;
  const auto i8 = ramp<std::int8_t>(12, -128, 21), i8b = ramp<std::int8_t>(12, 127, -20);
  Page p8 = page_of(4, 3, i8, SAMPLEFORMAT_INT), p8b = page_of(4, 3, i8b, SAMPLEFORMAT_INT);
  p8.compression = COMPRESSION_PACKBITS;
  write_tiff(dir.file("i8.tif"), {p8, p8b});
  VolumeFileInfo info;
  Volume v = load_tiff(dir.file("i8.tif"), -1, &info);
  EXPECT_EQ(v.type(), ScalarType::Int16);
  for (std::size_t i = 0; i < 12; ++i) {
    EXPECT_EQ(v.value(i), i8[i]);
    EXPECT_EQ(v.value(12 + i), i8b[i]);
  }
  EXPECT_TRUE(has_note(info, "int8 samples stored as int16"));

  const auto i16 = ramp<std::int16_t>(12, -32768, 5000);
  write_tiff(dir.file("i16.tif"), {page_of(4, 3, i16, SAMPLEFORMAT_INT)}, true);
  v = load_tiff(dir.file("i16.tif"));
  EXPECT_EQ(v.type(), ScalarType::Int16);
  for (std::size_t i = 0; i < 12; ++i) EXPECT_EQ(v.value(i), i16[i]);

  const auto u32 = ramp<std::uint32_t>(12, 0, 1000);
  write_tiff(dir.file("u32.tif"), {page_of(4, 3, u32, SAMPLEFORMAT_UINT)});
  v = load_tiff(dir.file("u32.tif"), -1, &info);
  EXPECT_EQ(v.type(), ScalarType::Float32);
  for (std::size_t i = 0; i < 12; ++i) EXPECT_EQ(v.value(i), static_cast<float>(u32[i]));
  EXPECT_TRUE(has_note(info, "uint32 samples stored as float32 (all exact)"));

  const std::vector<std::int32_t> i32{-2147483647 - 1, 16777217, 3, -5};
  write_tiff(dir.file("i32.tif"), {page_of(2, 2, i32, SAMPLEFORMAT_INT)});
  v = load_tiff(dir.file("i32.tif"), -1, &info);
  EXPECT_EQ(v.value(0), -2147483648.0f);
  EXPECT_EQ(v.value(3), -5);
  EXPECT_TRUE(has_note(info, "values beyond 2^24 rounded"));
}

TEST(TiffWrite, RgbSamplesAreChannels) {
  TempDir dir;
  std::vector<std::uint8_t> rgb(4 * 3 * 3);
  for (std::size_t i = 0; i < 12; ++i) rgb[3 * i] = static_cast<std::uint8_t>(i), rgb[3 * i + 1] = static_cast<std::uint8_t>(100 + i), rgb[3 * i + 2] = static_cast<std::uint8_t>(200 + i);
  Page contig = page_of(4, 3, rgb, SAMPLEFORMAT_UINT, 3);
  Page separate = contig;
  separate.planar = PLANARCONFIG_SEPARATE;
  Page tiled = separate;
  tiled.tile = 16;
  write_tiff(dir.file("contig.tif"), {contig, contig});
  write_tiff(dir.file("separate.tif"), {separate, separate});
  write_tiff(dir.file("tiled.tif"), {tiled});
  for (const char* name : {"contig.tif", "separate.tif", "tiled.tif"}) {
    SCOPED_TRACE(name);
    VolumeFileInfo info;
    const Volume r = load_tiff(dir.file(name), -1, &info);
    EXPECT_EQ(info.channels, 3);
    EXPECT_EQ(info.channel, 0);
    for (std::size_t i = 0; i < 12; ++i) EXPECT_EQ(r.value(i), static_cast<float>(i));
    const Volume b = load_tiff(dir.file(name), 2, &info);
    for (std::size_t i = 0; i < 12; ++i) EXPECT_EQ(b.value(i), static_cast<float>(200 + i));
    EXPECT_EQ(info.channel, 2);
    expect_error(dir.file(name), 3, {"channel 3 is out of range", "3 channels"});
  }
}

TEST(TiffWrite, MismatchedPagesNameThePage) {
  TempDir dir;
  const auto a = ramp<std::uint8_t>(12, 0, 1), b = ramp<std::uint8_t>(15, 0, 1);
  write_tiff(dir.file("size.tif"), {page_of(4, 3, a, SAMPLEFORMAT_UINT), page_of(4, 3, a, SAMPLEFORMAT_UINT), page_of(5, 3, b, SAMPLEFORMAT_UINT)});
  expect_error(dir.file("size.tif"), -1, {"page 2 is 5x3", "page 0 is 4x3", "same size"});
  const auto w = ramp<std::uint16_t>(12, 0, 1);
  write_tiff(dir.file("bits.tif"), {page_of(4, 3, a, SAMPLEFORMAT_UINT), page_of(4, 3, w, SAMPLEFORMAT_UINT)});
  expect_error(dir.file("bits.tif"), -1, {"page 1 is 4x3, 16-bit"});
}

TEST(TiffWrite, ResolutionWithoutImageJ) {
  TempDir dir;
  const auto a = ramp<std::uint8_t>(12, 0, 1);
  Page p = page_of(4, 3, a, SAMPLEFORMAT_UINT);
  p.xres = 10000, p.yres = 5000, p.res_unit = RESUNIT_CENTIMETER;  // 1 µm x 2 µm pixels
  write_tiff(dir.file("res.tif"), {p, p, p});
  VolumeFileInfo info;
  const Volume v = load_tiff(dir.file("res.tif"), -1, &info);
  EXPECT_EQ(v.dims()[2], 3);
  EXPECT_NEAR(v.spacing().x, 1.0, 1e-6);
  EXPECT_NEAR(v.spacing().y, 2.0, 1e-6);
  EXPECT_NEAR(v.spacing().z, 1.0, 1e-6);  // no z spacing: the x size
  EXPECT_TRUE(has_note(info, "no z spacing"));
  for (std::size_t i = 0; i < 36; ++i) EXPECT_EQ(v.value(i), a[i % 12]);
}

TEST(TiffWrite, ImageJHyperstackDeinterleaved) {
  TempDir dir;
  // 2 channels x 3 slices, pages z0c0 z0c1 z1c0 z1c1 z2c0 z2c1; page value = 10*z + c.
  std::vector<Page> pages;
  for (int z = 0; z < 3; ++z)
    for (int c = 0; c < 2; ++c) {
      Page p = page_of(4, 3, std::vector<std::uint16_t>(12, static_cast<std::uint16_t>(10 * z + c)), SAMPLEFORMAT_UINT);
      p.xres = p.yres = 4;  // 0.25 per pixel
      p.description = "ImageJ=1.54f\nimages=6\nchannels=2\nslices=3\nhyperstack=true\nunit=\\u00B5m\nspacing=2.5\nloop=false\n";
      pages.push_back(p);
    }
  write_tiff(dir.file("hyper.tif"), pages);
  VolumeFileInfo info;
  const Volume v = load_tiff(dir.file("hyper.tif"), 1, &info);
  ASSERT_EQ(v.dims(), (std::array<int, 3>{4, 3, 3}));
  for (int z = 0; z < 3; ++z) EXPECT_EQ(v.value(1, 1, z), 10 * z + 1);
  EXPECT_EQ(v.spacing(), (Vec3{0.25f, 0.25f, 2.5f}));
  EXPECT_EQ(info.channels, 2);
  EXPECT_TRUE(has_note(info, "ImageJ hyperstack: 2 channels x 3 slices, channel 1 loaded"));
  expect_error(dir.file("hyper.tif"), 5, {"channel 5 is out of range", "2 channels"});

  // A time series of single slices: the frames are z.
  for (auto& p : pages) p.description = "ImageJ=1.54f\nimages=6\nframes=6\nunit=nm\n";
  write_tiff(dir.file("frames.tif"), pages);
  const Volume t = load_tiff(dir.file("frames.tif"), -1, &info);
  EXPECT_EQ(t.dims()[2], 6);
  EXPECT_EQ(t.value(0, 0, 3), 11);
  EXPECT_NEAR(t.spacing().x, 0.25e-3, 1e-9);  // nm become µm
  EXPECT_TRUE(has_note(info, "frames are loaded as z"));

  for (auto& p : pages) p.description = "ImageJ=1.54f\nimages=7\nchannels=2\n";
  write_tiff(dir.file("lying.tif"), pages);
  expect_error(dir.file("lying.tif"), -1, {"images=7", "6 pages"});
  for (auto& p : pages) p.description = "ImageJ=1.54f\nimages=6\nchannels=4\n";
  write_tiff(dir.file("split.tif"), pages);
  expect_error(dir.file("split.tif"), -1, {"channels=4", "images=6"});
  for (auto& p : pages) p.description = "ImageJ=1.54f\nimages=2147483648\n";
  write_tiff(dir.file("huge.tif"), pages);
  expect_error(dir.file("huge.tif"), -1, {"images=2147483648", "not a count"});
}

TEST(TiffBad, TruncatedGarbageAndUnsupported) {
  TempDir dir;
  const auto a = ramp<std::uint16_t>(64 * 64, 0, 3);
  write_tiff(dir.file("ok.tif"), {page_of(64, 64, a, SAMPLEFORMAT_UINT), page_of(64, 64, a, SAMPLEFORMAT_UINT)});
  Bytes bytes = read_file(dir.file("ok.tif"));
  ASSERT_NO_THROW(load_tiff(dir.file("ok.tif")));
  // Cut inside the second page's pixels: the directories (written after the pixels) are gone too.
  write_file(dir.file("cut.tif"), Bytes(bytes.begin(), bytes.begin() + 9000));
  expect_error(dir.file("cut.tif"), -1, {"TIFF"});
  write_file(dir.file("garbage.tif"), std::string("this is not a TIFF file at all"));
  expect_error(dir.file("garbage.tif"), -1, {"not a TIFF file"});
  write_file(dir.file("empty.tif"), Bytes{});
  expect_error(dir.file("empty.tif"), -1, {"empty file"});

  // Pixels cut, tags intact: a page whose strip lies past the end of the file.
  Page p = page_of(64, 64, a, SAMPLEFORMAT_UINT);
  p.rows_per_strip = 64;
  write_tiff(dir.file("one.tif"), {p});
  bytes = read_file(dir.file("one.tif"));
  // libtiff writes the pixels at offset 8 and the directory after them: drop the last 4000 pixel bytes.
  Bytes holed(bytes.begin(), bytes.begin() + 8 + 8192 - 4000);
  const Bytes tail(bytes.begin() + 8 + 8192, bytes.end());
  holed.insert(holed.end(), tail.begin(), tail.end());
  // The directory offset in the header must follow the move.
  std::uint32_t ifd = 0;
  std::memcpy(&ifd, &holed[4], 4);
  ifd -= 4000;
  std::memcpy(&holed[4], &ifd, 4);
  write_file(dir.file("holed.tif"), holed);
  expect_error(dir.file("holed.tif"), -1, {"page"});

  // 1-bit pages.
  TIFF* tif = TIFFOpen(dir.file("bits1.tif").c_str(), "w");
  ASSERT_NE(tif, nullptr);
  TIFFSetField(tif, TIFFTAG_IMAGEWIDTH, 8);
  TIFFSetField(tif, TIFFTAG_IMAGELENGTH, 2);
  TIFFSetField(tif, TIFFTAG_BITSPERSAMPLE, 1);
  TIFFSetField(tif, TIFFTAG_SAMPLESPERPIXEL, 1);
  TIFFSetField(tif, TIFFTAG_PHOTOMETRIC, PHOTOMETRIC_MINISBLACK);
  unsigned char row[1] = {0x5a};
  TIFFWriteScanline(tif, row, 0, 0);
  TIFFWriteScanline(tif, row, 1, 0);
  TIFFClose(tif);
  expect_error(dir.file("bits1.tif"), -1, {"page 0 has 1-bit samples", "expected 8, 16 or 32"});

  // A page claiming a huge size with a tiny file.
  Page big = page_of(4, 3, ramp<std::uint8_t>(12, 0, 1), SAMPLEFORMAT_UINT);
  write_tiff(dir.file("big.tif"), {big});
  bytes = read_file(dir.file("big.tif"));
  // Patch ImageWidth and ImageLength (tags 256, 257 of type LONG or SHORT) to 60000 each.
  std::uint32_t off = 0;
  std::memcpy(&off, &bytes[4], 4);
  std::uint16_t entries = 0;
  std::memcpy(&entries, &bytes[off], 2);
  for (std::uint16_t e = 0; e < entries; ++e) {
    const std::size_t at = off + 2 + 12u * e;
    std::uint16_t tag = 0, type = 0;
    std::memcpy(&tag, &bytes[at], 2);
    std::memcpy(&type, &bytes[at + 2], 2);
    if (tag == 256 || tag == 257) {
      if (type == 3) {
        const std::uint16_t v = 60000;
        std::memcpy(&bytes[at + 8], &v, 2);
      } else {
        const std::uint32_t v = 60000;
        std::memcpy(&bytes[at + 8], &v, 4);
      }
    }
  }
  write_file(dir.file("big_claim.tif"), bytes);
  expect_error(dir.file("big_claim.tif"), -1, {"60000x60000"});
}

TEST(TiffBad, CutAndFlippedFilesGiveErrorsNotCrashes) {
  TempDir dir;
  const auto u16 = ramp<std::uint16_t>(12 * 10, 7, 333);
  Page lzw = page_of(12, 10, u16, SAMPLEFORMAT_UINT);
  lzw.compression = COMPRESSION_LZW;
  Page tiled = page_of(20, 18, ramp<float>(360, -3, 0.5), SAMPLEFORMAT_IEEEFP);
  tiled.tile = 16, tiled.compression = COMPRESSION_ADOBE_DEFLATE;
  Page hyper = page_of(6, 4, ramp<std::uint8_t>(24, 0, 9), SAMPLEFORMAT_UINT);
  hyper.description = "ImageJ=1.54f\nimages=4\nchannels=2\nslices=2\nunit=micron\nspacing=2\n";
  hyper.xres = hyper.yres = 2;
  int loaded = 0, refused = 0;
  for (const auto& [name, pages, big] : {std::tuple{"lzw.tif", std::vector<Page>{lzw, lzw}, true},
                                         std::tuple{"tiled.tif", std::vector<Page>{tiled, tiled}, false},
                                         std::tuple{"hyper.tif", std::vector<Page>{hyper, hyper, hyper, hyper}, false}}) {
    write_tiff(dir.file("src.tif"), pages, big);
    sweep(dir, name, read_file(dir.file("src.tif")), loaded, refused);
  }
  EXPECT_GT(loaded, 50);
  EXPECT_GT(refused, 50);
}
