// Multi-page TIFF stacks (.tif, .tiff) through libtiff: one page per z-slice, every page of the same
// width, height, bits and samples; 8/16/32-bit integer and 32/64-bit float samples in strips or tiles,
// uncompressed, LZW, deflate or PackBits, either byte order (libtiff decodes and swaps). ImageJ
// metadata (an ImageDescription starting "ImageJ=") gives the hyperstack layout (pages interleaved
// channel-fastest, then slices, then frames), which is de-interleaved, and the z spacing and unit.
// The voxel size is taken from XResolution/YResolution (pixels per unit) and ImageJ `spacing` only,
// never from ImageJ's Info block, which may describe an original image before cropping or scaling.
// Lengths in a known unit (micron, nm, mm, cm, inch) become µm. libtiff's messages never reach
// stderr: the first error of a file becomes part of one Error. Memory is guarded before allocating:
// the decoded size of the pages read must fit what the file could hold under its compression.
#include <tiffio.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdarg>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/text_fields.h"
#include "penumbra/data/io/volume_io.h"

namespace penumbra {

namespace {

using io_detail::bytes_str;
using io_detail::printable;
using io_detail::trim;

// More pages than this is not a stack (libtiff itself stops at 2^20 directories).
constexpr std::uint32_t kMaxPages = 1u << 20;
// Largest strip or tile buffer: real tiles and strips are far smaller.
constexpr std::uint64_t kMaxChunkBytes = 1ull << 28;

// ---- libtiff's messages ------------------------------------------------------------------------

// The first error libtiff reported for one open file; warnings are dropped.
struct TiffMessages {
  std::string error;
};

int on_tiff_error(TIFF*, void* user, const char* module, const char* fmt, va_list ap) {
  auto* messages = static_cast<TiffMessages*>(user);
  if (messages && messages->error.empty()) {
    char text[512];
    std::vsnprintf(text, sizeof text, fmt, ap);
    messages->error = printable(module && *module ? std::string(module) + ": " + text : std::string(text));
  }
  return 1;  // handled: libtiff calls no global handler after this
}

int on_tiff_warning(TIFF*, void*, const char*, const char*, va_list) { return 1; }

struct TiffClose {
  void operator()(TIFF* t) const { TIFFClose(t); }
};
using TiffFile = std::unique_ptr<TIFF, TiffClose>;

TiffFile open_tiff(const std::string& path, TiffMessages& messages) {
  // Messages raised where libtiff has no file handle go to the global handlers: silence those once.
  static std::once_flag silenced;
  std::call_once(silenced, [] {
    TIFFSetErrorHandler(nullptr);
    TIFFSetWarningHandler(nullptr);
  });
  std::unique_ptr<TIFFOpenOptions, void (*)(TIFFOpenOptions*)> options(TIFFOpenOptionsAlloc(), TIFFOpenOptionsFree);
  if (!options) throw Error("libtiff could not allocate its options");
  TIFFOpenOptionsSetMaxSingleMemAlloc(options.get(), static_cast<tmsize_t>(kMaxChunkBytes));
  TIFFOpenOptionsSetErrorHandlerExtR(options.get(), on_tiff_error, &messages);
  TIFFOpenOptionsSetWarningHandlerExtR(options.get(), on_tiff_warning, nullptr);
  // "m": read, not memory-mapped: a window of pages then holds only what it decodes
  TiffFile tif(TIFFOpenExt(path.c_str(), "rm", options.get()));
  if (!tif)
    throw Error("not a TIFF file libtiff can read (" + (messages.error.empty() ? std::string("no detail") : messages.error) + ")");
  return tif;
}

std::string libtiff_says(const TiffMessages& messages) {
  return messages.error.empty() ? std::string() : " (libtiff: " + messages.error + ")";
}

// ---- one page's layout -------------------------------------------------------------------------

struct PageLayout {
  std::uint32_t width = 0, height = 0;
  std::uint16_t bits = 1, samples = 1, format = SAMPLEFORMAT_UINT;
  std::uint16_t planar = PLANARCONFIG_CONTIG, compression = COMPRESSION_NONE, photometric = PHOTOMETRIC_MINISBLACK;

  bool same_shape(const PageLayout& o) const {
    return width == o.width && height == o.height && bits == o.bits && samples == o.samples && format == o.format;
  }
  std::string str() const {
    const char* kind = format == SAMPLEFORMAT_IEEEFP ? "float" : format == SAMPLEFORMAT_INT ? "signed" : "unsigned";
    return std::to_string(width) + "x" + std::to_string(height) + ", " + std::to_string(bits) + "-bit " + kind + ", " +
           std::to_string(samples) + (samples == 1 ? " sample" : " samples") + " per pixel";
  }
  std::size_t sample_bytes() const { return bits / 8u; }
};

// Largest decoded-to-stored size ratio of a compression (PackBits: 2 bytes make at most 128; deflate:
// about 1032:1; LZW: a 12-bit code stands for at most 4096 bytes).
std::uint64_t max_expansion(std::uint16_t compression) {
  switch (compression) {
    case COMPRESSION_NONE: return 1;
    case COMPRESSION_PACKBITS: return 64;
    case COMPRESSION_ADOBE_DEFLATE: case COMPRESSION_DEFLATE: return io_detail::kMaxDeflateRatio;
    default: return 4096;  // LZW
  }
}

PageLayout read_layout(TIFF* tif, std::uint32_t page) {
  const std::string where = "page " + std::to_string(page);
  PageLayout p;
  if (!TIFFGetField(tif, TIFFTAG_IMAGEWIDTH, &p.width) || !TIFFGetField(tif, TIFFTAG_IMAGELENGTH, &p.height))
    throw Error(where + " has no ImageWidth or ImageLength tag");
  TIFFGetFieldDefaulted(tif, TIFFTAG_BITSPERSAMPLE, &p.bits);
  TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLESPERPIXEL, &p.samples);
  TIFFGetFieldDefaulted(tif, TIFFTAG_SAMPLEFORMAT, &p.format);
  TIFFGetFieldDefaulted(tif, TIFFTAG_PLANARCONFIG, &p.planar);
  TIFFGetFieldDefaulted(tif, TIFFTAG_COMPRESSION, &p.compression);
  TIFFGetField(tif, TIFFTAG_PHOTOMETRIC, &p.photometric);
  if (p.format == SAMPLEFORMAT_VOID) p.format = SAMPLEFORMAT_UINT;
  const auto max_side = static_cast<std::uint32_t>(std::numeric_limits<int>::max());
  if (p.width == 0 || p.height == 0 || p.width > max_side || p.height > max_side)
    throw Error(where + " is " + std::to_string(p.width) + "x" + std::to_string(p.height) + " pixels (expected 1 to 2^31-1 a side)");
  if (p.samples == 0) throw Error(where + " has 0 samples per pixel");
  const bool integer = p.format == SAMPLEFORMAT_UINT || p.format == SAMPLEFORMAT_INT;
  const bool ok = (integer && (p.bits == 8 || p.bits == 16 || p.bits == 32)) ||
                  (p.format == SAMPLEFORMAT_IEEEFP && (p.bits == 32 || p.bits == 64));
  if (!ok)
    throw Error(where + " has " + std::to_string(p.bits) + "-bit samples of format " + std::to_string(p.format) +
                " (expected 8, 16 or 32-bit integers or 32/64-bit floats)");
  if (p.photometric == PHOTOMETRIC_YCBCR) throw Error(where + " is YCbCr (expected grey, RGB or separate channels)");
  if (p.planar != PLANARCONFIG_CONTIG && p.planar != PLANARCONFIG_SEPARATE)
    throw Error(where + " has PlanarConfiguration " + std::to_string(p.planar) + " (expected 1 or 2)");
  switch (p.compression) {
    case COMPRESSION_NONE: case COMPRESSION_LZW: case COMPRESSION_ADOBE_DEFLATE: case COMPRESSION_DEFLATE:
    case COMPRESSION_PACKBITS: break;
    default: {
      const TIFFCodec* codec = TIFFFindCODEC(p.compression);
      throw Error(where + " uses compression " + (codec ? std::string(codec->name) + " " : std::string()) + "(" +
                  std::to_string(p.compression) + "; supported: none, LZW, deflate, PackBits)");
    }
  }
  return p;
}

// ---- ImageJ metadata ---------------------------------------------------------------------------

struct ImageJInfo {
  bool present = false;
  std::uint32_t images = 0, channels = 1, slices = 0, frames = 1;
  std::optional<double> spacing;
  std::string unit;
};

std::uint32_t imagej_count(std::string_view key, std::string_view value) {
  double v = 0;
  if (!io_detail::parse_number(value, v) || !(v >= 1 && v <= kMaxPages) || v != std::floor(v))
    throw Error("ImageJ metadata " + std::string(key) + "=" + printable(value, 40) + " is not a count from 1 to " +
                std::to_string(kMaxPages));
  return static_cast<std::uint32_t>(v);
}

ImageJInfo parse_imagej(const char* description) {
  ImageJInfo ij;
  if (!description || std::strncmp(description, "ImageJ=", 7) != 0) return ij;
  ij.present = true;
  io_detail::LineReader lines(description);
  std::string_view line;
  while (lines.next(line)) {
    const std::size_t eq = line.find('=');
    if (eq == std::string_view::npos) continue;
    const std::string_view key = trim(line.substr(0, eq)), value = trim(line.substr(eq + 1));
    if (key == "images") ij.images = imagej_count(key, value);
    else if (key == "channels") ij.channels = imagej_count(key, value);
    else if (key == "slices") ij.slices = imagej_count(key, value);
    else if (key == "frames") ij.frames = imagej_count(key, value);
    else if (key == "unit") ij.unit = std::string(value);
    else if (key == "spacing") {
      double v = 0;
      if (!io_detail::parse_number(value, v) || !std::isfinite(v) || v == 0 || std::abs(v) > 1e30)
        throw Error("ImageJ metadata spacing=" + printable(value, 40) + " is not a voxel depth");
      ij.spacing = std::abs(v);  // ImageJ writes a negative spacing for a stack taken top-down
    }
  }
  return ij;
}

// µm per unit for the length units ImageJ writes (ImageJ escapes µ as \u00B5); 0 when unknown.
double microns_per(const std::string& unit) {
  static const char* const micron[] = {"micron", "microns", "um", "\xC2\xB5m", "\xB5m", "\\u00B5m", "\xCE\xBCm"};
  for (const char* m : micron)
    if (unit == m) return 1;
  if (unit == "nm" || unit == "nanometer") return 1e-3;
  if (unit == "mm" || unit == "millimeter") return 1e3;
  if (unit == "cm" || unit == "centimeter") return 1e4;
  if (unit == "m" || unit == "meter") return 1e6;
  if (unit == "inch" || unit == "in") return 25400;
  return 0;
}

// ---- which pages make the volume ---------------------------------------------------------------

struct StackPlan {
  std::uint32_t depth = 0;       // z-slices loaded
  std::uint32_t page_step = 1;   // page of slice k: k * page_step + page_first
  std::uint32_t page_first = 0;
  int channels = 1, channel = 0;
  std::uint16_t sample = 0;      // sample within a pixel
};

StackPlan plan_stack(const ImageJInfo& ij, std::uint32_t pages, const PageLayout& layout, int channel,
                     std::vector<std::string>& notes) {
  StackPlan plan;
  std::uint32_t ij_channels = 1;
  std::string layout_note;
  if (ij.present && (ij.images > 1 || pages > 1)) {
    const std::uint32_t images = ij.images ? ij.images : pages;
    if (images != pages)
      throw Error("ImageJ metadata says images=" + std::to_string(images) + " but the file has " + std::to_string(pages) +
                  " pages (ImageJ files over 4 GB keep only the first page's tags: not supported)");
    ij_channels = ij.channels;
    const std::uint64_t per_slice = std::uint64_t{ij.channels} * ij.frames;
    const std::uint64_t slices = ij.slices ? ij.slices : images / per_slice;
    if (slices * per_slice != images)
      throw Error("ImageJ metadata channels=" + std::to_string(ij.channels) + " x slices=" + std::to_string(slices) +
                  " x frames=" + std::to_string(ij.frames) + " does not make images=" + std::to_string(images));
    const bool frames_as_z = slices == 1 && ij.frames > 1;
    plan.depth = frames_as_z ? ij.frames : static_cast<std::uint32_t>(slices);
    plan.page_step = ij_channels;
    if (ij_channels > 1 || ij.frames > 1)
      layout_note = "ImageJ hyperstack: " + std::to_string(ij_channels) + " channels x " + std::to_string(slices) + " slices" +
                    (ij.frames > 1 ? " x " + std::to_string(ij.frames) + " frames" : "");
    if (frames_as_z) notes.push_back("a time series of single slices: its " + std::to_string(ij.frames) + " frames are loaded as z");
    else if (ij.frames > 1) layout_note += ", frame 0";
  } else {
    plan.depth = pages;
  }
  if (ij_channels > 1 && layout.samples > 1)
    throw Error("ImageJ channels=" + std::to_string(ij_channels) + " with " + std::to_string(layout.samples) +
                " samples per pixel (expected one of the two to be 1)");
  plan.channels = static_cast<int>(std::max<std::uint32_t>(ij_channels, layout.samples));
  plan.channel = channel < 0 ? 0 : channel;
  if (plan.channel >= plan.channels)
    throw Error("channel " + std::to_string(plan.channel) + " is out of range: the file has " + std::to_string(plan.channels) +
                (plan.channels == 1 ? " channel (channel 0)" : " channels (0 to " + std::to_string(plan.channels - 1) + ")"));
  if (ij_channels > 1) plan.page_first = static_cast<std::uint32_t>(plan.channel);
  else plan.sample = static_cast<std::uint16_t>(plan.channel);
  if (layout_note.empty() && plan.channels > 1)
    layout_note = std::to_string(layout.samples) + " samples per pixel taken as channels";
  if (!layout_note.empty()) notes.push_back(layout_note + ", channel " + std::to_string(plan.channel) + " loaded");
  return plan;
}

// ---- reading pages -----------------------------------------------------------------------------

// Copies `rows` x `cols` samples from a decoded chunk (row stride `chunk_row` bytes, `step` samples
// between pixels, starting at sample `first`) to the page at (x0, y0).
void copy_block(const std::byte* chunk, std::size_t chunk_row, std::size_t step, std::size_t first, std::uint32_t rows,
                std::uint32_t cols, std::byte* page, std::uint32_t width, std::uint32_t x0, std::uint32_t y0, std::size_t bytes) {
  for (std::uint32_t r = 0; r < rows; ++r) {
    const std::byte* src = chunk + r * chunk_row + first * bytes;
    std::byte* dst = page + (static_cast<std::size_t>(y0 + r) * width + x0) * bytes;
    if (step == 1) {
      std::memcpy(dst, src, cols * bytes);
    } else {
      for (std::uint32_t c = 0; c < cols; ++c) std::memcpy(dst + c * bytes, src + c * step * bytes, bytes);
    }
  }
}

// Decodes one sample of every pixel of the current page into `page` (width*height samples, native byte order).
void read_page(TIFF* tif, const PageLayout& p, std::uint16_t sample, std::uint32_t page_no, const TiffMessages& messages,
               std::vector<std::byte>& chunk, std::byte* page) {
  const std::string where = "page " + std::to_string(page_no);
  const bool contig = p.planar == PLANARCONFIG_CONTIG;
  const std::size_t bytes = p.sample_bytes(), step = contig ? p.samples : 1, first = contig ? sample : 0;
  const auto fail = [&](const std::string& what, tmsize_t got, std::uint64_t want) {
    return Error("cannot decode " + where + " " + what + ": got " + bytes_str(got < 0 ? 0 : static_cast<std::uint64_t>(got)) +
                 " of " + bytes_str(want) + libtiff_says(messages));
  };
  if (TIFFIsTiled(tif)) {
    std::uint32_t tw = 0, th = 0;
    if (!TIFFGetField(tif, TIFFTAG_TILEWIDTH, &tw) || !TIFFGetField(tif, TIFFTAG_TILELENGTH, &th) || tw == 0 || th == 0)
      throw Error(where + " is tiled without a valid TileWidth and TileLength");
    const std::uint64_t tile_bytes = std::uint64_t{tw} * th * step * bytes;
    if (tile_bytes > kMaxChunkBytes) throw Error(where + " has tiles of " + bytes_str(tile_bytes) + " (too large)");
    chunk.resize(static_cast<std::size_t>(tile_bytes));
    for (std::uint64_t y64 = 0; y64 < p.height; y64 += th) {
      for (std::uint64_t x64 = 0; x64 < p.width; x64 += tw) {
        const auto x = static_cast<std::uint32_t>(x64), y = static_cast<std::uint32_t>(y64);
        const std::uint32_t tile = TIFFComputeTile(tif, x, y, 0, contig ? 0 : sample);
        if (tile >= TIFFNumberOfTiles(tif)) throw Error(where + " has fewer tiles than its size needs");
        const tmsize_t got = TIFFReadEncodedTile(tif, tile, chunk.data(), static_cast<tmsize_t>(tile_bytes));
        if (got != static_cast<tmsize_t>(tile_bytes)) throw fail("tile " + std::to_string(tile), got, tile_bytes);
        copy_block(chunk.data(), tw * step * bytes, step, first, std::min(th, p.height - y), std::min(tw, p.width - x),
                   page, p.width, x, y, bytes);
      }
    }
    return;
  }
  std::uint32_t rows_per_strip = 0;
  TIFFGetFieldDefaulted(tif, TIFFTAG_ROWSPERSTRIP, &rows_per_strip);
  rows_per_strip = rows_per_strip == 0 ? p.height : std::min(rows_per_strip, p.height);
  const std::uint32_t strips = (p.height - 1) / rows_per_strip + 1;
  const std::uint64_t row_bytes = std::uint64_t{p.width} * step * bytes;
  if (row_bytes * rows_per_strip > kMaxChunkBytes)
    throw Error(where + " has strips of " + bytes_str(row_bytes * rows_per_strip) + " (too large)");
  if (TIFFNumberOfStrips(tif) < (contig ? strips : std::uint64_t{strips} * p.samples))
    throw Error(where + " has " + std::to_string(TIFFNumberOfStrips(tif)) + " strips but its size needs " +
                std::to_string(contig ? strips : std::uint64_t{strips} * p.samples));
  chunk.resize(static_cast<std::size_t>(row_bytes * rows_per_strip));
  for (std::uint32_t s = 0; s < strips; ++s) {
    const std::uint32_t y = s * rows_per_strip, rows = std::min(rows_per_strip, p.height - y);
    const std::uint32_t strip = contig ? s : sample * strips + s;
    const std::uint64_t want = row_bytes * rows;
    const tmsize_t got = TIFFReadEncodedStrip(tif, strip, chunk.data(), static_cast<tmsize_t>(want));
    if (got != static_cast<tmsize_t>(want)) throw fail("strip " + std::to_string(strip), got, want);
    copy_block(chunk.data(), static_cast<std::size_t>(row_bytes), step, first, rows, p.width, page, p.width, 0, y, bytes);
  }
}

// The volume type samples are kept in: int8 widens to int16, 32-bit integers and float64 become float32.
ScalarType volume_type(const PageLayout& p) {
  if (p.format == SAMPLEFORMAT_IEEEFP || p.bits == 32) return ScalarType::Float32;
  if (p.bits == 8) return p.format == SAMPLEFORMAT_INT ? ScalarType::Int16 : ScalarType::UInt8;
  return p.format == SAMPLEFORMAT_INT ? ScalarType::Int16 : ScalarType::UInt16;
}

template <class Src, class Dst>
bool convert_samples(const std::byte* in, std::size_t n, Dst* out) {
  bool exact = true;
  for (std::size_t i = 0; i < n; ++i) {
    Src v;
    std::memcpy(&v, in + i * sizeof(Src), sizeof(Src));
    if constexpr (std::is_same_v<Src, double>) {
      if (std::abs(v) > std::numeric_limits<float>::max())
        throw Error("sample value " + num(v) + " is outside the float32 range");
    }
    out[i] = static_cast<Dst>(v);
    if constexpr (std::is_integral_v<Src> && sizeof(Src) == 4) exact = exact && static_cast<Src>(out[i]) == v;
  }
  return exact;
}

// Converts one page of samples into slice k of the volume; false when a value was rounded.
bool store_page(const std::byte* page, const PageLayout& p, Volume& volume, std::size_t k) {
  const std::size_t n = std::size_t{p.width} * p.height, offset = k * n;
  const bool sign = p.format == SAMPLEFORMAT_INT;
  if (p.format == SAMPLEFORMAT_IEEEFP) {
    if (p.bits == 64) return convert_samples<double>(page, n, volume.data_as<float>() + offset);
  } else if (p.bits == 32) {
    return sign ? convert_samples<std::int32_t>(page, n, volume.data_as<float>() + offset)
                : convert_samples<std::uint32_t>(page, n, volume.data_as<float>() + offset);
  } else if (p.bits == 8 && sign) {
    return convert_samples<std::int8_t>(page, n, volume.data_as<std::int16_t>() + offset);
  }
  std::memcpy(volume.data() + offset * p.sample_bytes(), page, n * p.sample_bytes());  // stored as is
  return true;
}

// ---- voxel size --------------------------------------------------------------------------------

Vec3 voxel_size(TIFF* tif, const ImageJInfo& ij, std::vector<std::string>& notes) {
  float xres = 0, yres = 0;
  std::uint16_t res_unit = RESUNIT_INCH;
  const bool has_x = TIFFGetField(tif, TIFFTAG_XRESOLUTION, &xres) && std::isfinite(xres) && xres > 0;
  const bool has_y = TIFFGetField(tif, TIFFTAG_YRESOLUTION, &yres) && std::isfinite(yres) && yres > 0;
  TIFFGetFieldDefaulted(tif, TIFFTAG_RESOLUTIONUNIT, &res_unit);
  if (!has_x && !has_y && !ij.spacing) {
    notes.push_back("no voxel size in the file: spacing 1");
    return {1, 1, 1};
  }
  std::string unit;
  double factor = 1;  // µm per file unit, or 1 when the unit is unknown
  if (ij.present && !ij.unit.empty()) {
    factor = microns_per(ij.unit);
    unit = factor > 0 ? "\u00b5m" : ij.unit;
    if (factor == 0) factor = 1;
  } else if (!ij.present && res_unit == RESUNIT_INCH) {
    factor = 25400, unit = "\u00b5m";
  } else if (!ij.present && res_unit == RESUNIT_CENTIMETER) {
    factor = 1e4, unit = "\u00b5m";
  }
  const double sx = has_x ? 1.0 / xres : has_y ? 1.0 / yres : 1.0;
  const double sy = has_y ? 1.0 / yres : sx;
  double sz = ij.spacing.value_or(ij.present ? 1.0 : sx);  // ImageJ omits spacing=1
  if (!ij.spacing && !ij.present) notes.push_back("no z spacing in the file: z spacing set to the x pixel size");
  const Vec3 size{static_cast<float>(sx * factor), static_cast<float>(sy * factor), static_cast<float>(sz * factor)};
  if (!(size.x > 0 && size.y > 0 && size.z > 0 && std::isfinite(size.x) && std::isfinite(size.y) && std::isfinite(size.z)))
    throw Error("voxel size " + num(sx * factor) + " x " + num(sy * factor) + " x " + num(sz * factor) + " is not positive and finite");
  notes.push_back("voxel size " + num(size.x) + " x " + num(size.y) + " x " + num(size.z) +
                  (unit.empty() ? std::string(" (unit not stated)") : " " + unit) +
                  (has_x || has_y ? "" : " (no XResolution: x and y spacing 1)"));
  return size;
}

}  // namespace

Volume load_tiff_volume(const std::string& path, int channel, VolumeFileInfo* info, const SliceChooser* choose, WindowRead* read) {
  if (read) *read = WindowRead{};
  VolumeFileInfo local;
  VolumeFileInfo& out = info ? *info : local;
  out.format = "tiff";
  const std::uint64_t file_bytes = io_detail::regular_file_size(path);
  if (file_bytes == 0) throw Error("empty file (expected a TIFF header)");
  TiffMessages messages;
  TiffFile file = open_tiff(path, messages);
  TIFF* tif = file.get();

  // First pass: every page's layout, which must match page 0's.
  const char* description = nullptr;
  const ImageJInfo ij = parse_imagej(TIFFGetField(tif, TIFFTAG_IMAGEDESCRIPTION, &description) ? description : nullptr);
  const PageLayout layout = read_layout(tif, 0);
  std::vector<std::string> size_notes;
  const Vec3 spacing = voxel_size(tif, ij, size_notes);
  std::vector<std::uint16_t> compression{layout.compression};
  while (TIFFReadDirectory(tif)) {
    const auto page = static_cast<std::uint32_t>(compression.size());
    if (page >= kMaxPages) throw Error("more than " + std::to_string(kMaxPages) + " pages (not an image stack)");
    const PageLayout p = read_layout(tif, page);
    if (!p.same_shape(layout))
      throw Error("page " + std::to_string(page) + " is " + p.str() + " but page 0 is " + layout.str() +
                  " (every page of a stack must have the same size, bits and samples)");
    compression.push_back(p.compression);
  }
  if (!messages.error.empty())
    throw Error("cannot read the directory of page " + std::to_string(compression.size()) + libtiff_says(messages));
  const auto pages = static_cast<std::uint32_t>(compression.size());

  const StackPlan plan = plan_stack(ij, pages, layout, channel, out.notes);
  out.channels = plan.channels;
  out.channel = plan.channel;
  const std::array<std::int64_t, 3> dims{layout.width, layout.height, plan.depth};
  const std::string dims_text = std::to_string(dims[0]) + "x" + std::to_string(dims[1]) + "x" + std::to_string(dims[2]);
  (void)with_context("TIFF stack " + dims_text, [&] { return checked_voxel_count(dims); });
  // What the file could hold: the decoded pages must fit its size times their compression's ratio.
  const std::uint64_t page_bytes = std::uint64_t{layout.width} * layout.height * layout.samples * layout.sample_bytes();
  std::uint64_t stored_min = 0;
  for (std::uint32_t k = 0; k < plan.depth; ++k)
    stored_min += page_bytes / max_expansion(compression[k * plan.page_step + plan.page_first]);
  if (stored_min > file_bytes)
    throw Error(std::to_string(plan.depth) + " pages of " + layout.str() + " need " + bytes_str(page_bytes) +
                " each decoded, more than the " + bytes_str(file_bytes) + " file could hold (truncated file or lying tags)");

  const ScalarType type = volume_type(layout);
  if (type == ScalarType::Int16 && layout.bits == 8) out.notes.push_back("int8 samples stored as int16");
  if (type == ScalarType::Float32 && layout.bits != 32)
    out.notes.push_back("float64 samples stored as float32");
  const std::array<int, 3> whole{static_cast<int>(layout.width), static_cast<int>(layout.height), static_cast<int>(plan.depth)};
  const SliceRange slices = choose ? checked_slices(*choose, whole) : SliceRange{0, whole[2]};
  Volume volume(type, {whole[0], whole[1], slices.count}, spacing, {0, 0, 0}, VoxelFill::Uninitialized);

  // Second pass: the pages of the chosen slices (of the chosen channel and frame 0), in order.
  const std::uint32_t first_page = static_cast<std::uint32_t>(slices.first) * plan.page_step + plan.page_first;
  if (!TIFFSetDirectory(tif, static_cast<tdir_t>(first_page)))
    throw Error("cannot go to page " + std::to_string(first_page) + libtiff_says(messages));
  std::vector<std::byte> chunk, page(static_cast<std::size_t>(std::uint64_t{layout.width} * layout.height * layout.sample_bytes()));
  bool exact = true;
  std::uint32_t current = first_page;
  std::uint64_t stored_bytes = 0;
  for (int k = 0; k < slices.count; ++k) {
    const std::uint32_t want = static_cast<std::uint32_t>(slices.first + k) * plan.page_step + plan.page_first;
    for (; current < want; ++current)
      if (!TIFFReadDirectory(tif)) throw Error("cannot read the directory of page " + std::to_string(current + 1) + libtiff_says(messages));
    const PageLayout p = read_layout(tif, want);
    read_page(tif, p, plan.sample, want, messages, chunk, page.data());
    exact = store_page(page.data(), p, volume, static_cast<std::size_t>(k)) && exact;
    for (std::uint32_t s = 0, n = TIFFNumberOfStrips(tif); s < n; ++s) stored_bytes += TIFFGetStrileByteCount(tif, s);
  }
  if (slices.count < whole[2]) volume.set_window(slices.first, whole[2]);
  if (read) read->bytes_read = stored_bytes;
  if (layout.bits == 32 && layout.format != SAMPLEFORMAT_IEEEFP)
    out.notes.push_back(std::string(layout.format == SAMPLEFORMAT_INT ? "int32" : "uint32") + " samples stored as float32" +
                        (exact ? " (all exact)" : " (values beyond 2^24 rounded)"));
  if (layout.photometric == PHOTOMETRIC_PALETTE) out.notes.push_back("palette image: the palette indices are loaded");

  out.notes.insert(out.notes.end(), size_notes.begin(), size_notes.end());
  volume.recompute_range();  // rejects NaN/inf voxels and gives the volume its range
  return volume;
}

}  // namespace penumbra
