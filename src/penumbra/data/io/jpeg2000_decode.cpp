// JPEG 2000 frames of DICOM pixel data decoded with OpenJPEG called directly (see jpeg2000_decode.h for
// why not through GDCM): the codestream's main header is checked here first, then OpenJPEG reads it from
// memory through bounds-checked callbacks, and its result is checked before a value is stored.
#include "penumbra/data/io/jpeg2000_decode.h"

#include <openjpeg.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <type_traits>

#include "penumbra/core/error.h"
#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/text_fields.h"

namespace penumbra::io_detail {

namespace {

// OpenJPEG holds the decoded image as int32 values plus its tile and code-block buffers (several times
// the output), so a frame is decoded up to 2^26 pixels (8192 x 8192, about half a GB in OpenJPEG). It
// must be Rows x Columns anyway (checked first).
constexpr std::uint64_t kMaxPixels = std::uint64_t{1} << 26;
// OpenJPEG allocates the coding parameters of every tile while reading the main header (it takes up to
// 65535); real images have one tile or a few.
constexpr std::uint64_t kMaxTiles = 4096;
// The messages of OpenJPEG kept for an Error, at most this long.
constexpr std::size_t kMaxMessageChars = 600;

using Bytes = std::span<const unsigned char>;

std::uint32_t be16(Bytes d, std::size_t i) { return static_cast<std::uint32_t>(d[i] << 8 | d[i + 1]); }
std::uint32_t be32(Bytes d, std::size_t i) { return be16(d, i) << 16 | be16(d, i + 2); }

std::string hex_bytes(Bytes d, std::size_t n) {
  std::string out;
  for (std::size_t i = 0; i < std::min(n, d.size()); ++i) {
    char s[4];
    std::snprintf(s, sizeof s, "%s%02X", i ? " " : "", d[i]);
    out += s;
  }
  return out.empty() ? "nothing" : out;
}

std::string box_type(std::uint32_t t) {
  const char s[4] = {static_cast<char>(t >> 24), static_cast<char>(t >> 16), static_cast<char>(t >> 8), static_cast<char>(t)};
  return printable(std::string_view(s, 4));
}

// The J2K codestream: `d` itself, or the contents of a JP2 file's contiguous codestream box ('jp2c'; the
// JP2 header boxes, colour and palette among them, are not read: a DICOM frame is the codestream).
Bytes codestream_of(Bytes d) {
  static constexpr unsigned char kJp2Signature[12] = {0x00, 0x00, 0x00, 0x0C, 0x6A, 0x50, 0x20, 0x20, 0x0D, 0x0A, 0x87, 0x0A};
  if (d.size() >= 2 && be16(d, 0) == 0xFF4F) return d;  // SOC
  if (d.size() >= sizeof kJp2Signature && std::equal(std::begin(kJp2Signature), std::end(kJp2Signature), d.begin())) {
    for (std::size_t at = 0; d.size() - at >= 8;) {
      std::uint64_t length = be32(d, at), header = 8;
      const std::uint32_t type = be32(d, at + 4);
      if (length == 1) {  // a 64-bit length follows
        if (d.size() - at < 16) break;
        length = std::uint64_t{be32(d, at + 8)} << 32 | be32(d, at + 12);
        header = 16;
      } else if (length == 0) {  // the last box, to the end
        length = d.size() - at;
      }
      if (length < header || length > d.size() - at)
        throw Error("JP2 box '" + box_type(type) + "' at byte " + std::to_string(at) + " claims " + bytes_str(length) + " but " +
                    bytes_str(d.size() - at) + " remain in the pixel data");
      if (type == 0x6A703263) return d.subspan(static_cast<std::size_t>(at + header), static_cast<std::size_t>(length - header));  // 'jp2c'
      at += static_cast<std::size_t>(length);
    }
    throw Error("JP2 file without a codestream box ('jp2c')");
  }
  throw Error("JPEG 2000 pixel data starts with " + hex_bytes(d, 4) + " (expected a J2K codestream, FF 4F FF 51, or a JP2 file)");
}

struct Siz {
  unsigned precision = 0;  // bits of a value
  bool is_signed = false;
};

// Reads the SIZ marker segment (the main header's first, right after SOC) and checks it against the frame.
Siz read_siz(Bytes cs, const Jpeg2000Frame& frame) {
  if (cs.size() < 2 || be16(cs, 0) != 0xFF4F) throw Error("JPEG 2000 codestream does not start with an SOC marker (FF 4F)");
  if (cs.size() < 4 || be16(cs, 2) != 0xFF51)
    throw Error("JPEG 2000 codestream without a SIZ marker segment after SOC (found " + hex_bytes(cs.subspan(std::min<std::size_t>(2, cs.size())), 2) +
                ", expected FF 51)");
  if (cs.size() < 42) throw Error("JPEG 2000 SIZ marker segment runs past the end of the pixel data");
  const std::uint32_t length = be16(cs, 4), components = be16(cs, 40);
  const std::uint64_t xsiz = be32(cs, 8), ysiz = be32(cs, 12), x0 = be32(cs, 16), y0 = be32(cs, 20);
  const std::uint64_t tile_w = be32(cs, 24), tile_h = be32(cs, 28), tile_x0 = be32(cs, 32), tile_y0 = be32(cs, 36);
  if (components != 1)
    throw Error("JPEG 2000 codestream with " + std::to_string(components) + " components (expected 1, as SamplesPerPixel says)");
  if (length != 41) throw Error("JPEG 2000 SIZ marker segment of " + bytes_str(length) + " (expected 41 for one component)");
  if (cs.size() < 45) throw Error("JPEG 2000 SIZ marker segment runs past the end of the pixel data");
  const unsigned ssiz = cs[42], dx = cs[43], dy = cs[44];
  if (xsiz <= x0 || ysiz <= y0)
    throw Error("JPEG 2000 image area from (" + std::to_string(x0) + ", " + std::to_string(y0) + ") to (" + std::to_string(xsiz) + ", " +
                std::to_string(ysiz) + ") is empty");
  const std::uint64_t width = xsiz - x0, height = ysiz - y0;
  if (width != static_cast<std::uint64_t>(frame.cols) || height != static_cast<std::uint64_t>(frame.rows))
    throw Error("JPEG 2000 codestream of " + std::to_string(width) + "x" + std::to_string(height) + " pixels (expected " +
                std::to_string(frame.cols) + "x" + std::to_string(frame.rows) + ", as Columns and Rows say)");
  if (width * height > kMaxPixels)
    throw Error("JPEG 2000 frame of " + std::to_string(width) + "x" + std::to_string(height) + " pixels (frames are decoded up to " +
                std::to_string(kMaxPixels) + " pixels)");
  if (dx != 1 || dy != 1)
    throw Error("JPEG 2000 component subsampled by " + std::to_string(dx) + "x" + std::to_string(dy) + " (expected 1x1)");
  if (tile_w == 0 || tile_h == 0 || tile_x0 > x0 || tile_y0 > y0 || tile_x0 + tile_w <= x0 || tile_y0 + tile_h <= y0)
    throw Error("JPEG 2000 tiles of " + std::to_string(tile_w) + "x" + std::to_string(tile_h) + " from (" + std::to_string(tile_x0) + ", " +
                std::to_string(tile_y0) + ") do not cover the image's first pixel at (" + std::to_string(x0) + ", " + std::to_string(y0) + ")");
  const std::uint64_t tiles = ((xsiz - tile_x0 + tile_w - 1) / tile_w) * ((ysiz - tile_y0 + tile_h - 1) / tile_h);
  if (tiles > kMaxTiles)
    throw Error("JPEG 2000 codestream of " + std::to_string(tiles) + " tiles of " + std::to_string(tile_w) + "x" + std::to_string(tile_h) +
                " pixels (expected at most " + std::to_string(kMaxTiles) + ")");
  Siz siz;
  siz.precision = (ssiz & 0x7F) + 1;
  siz.is_signed = (ssiz & 0x80) != 0;
  if (siz.precision > static_cast<unsigned>(frame.bits_allocated))
    throw Error("JPEG 2000 values of " + std::to_string(siz.precision) + " bits (expected at most BitsAllocated, " +
                std::to_string(frame.bits_allocated) + ")");
  return siz;
}

void check_frame(const Jpeg2000Frame& frame) {
  if (frame.rows <= 0 || frame.cols <= 0 || (frame.bits_allocated != 8 && frame.bits_allocated != 16 && frame.bits_allocated != 32))
    throw Error("JPEG 2000 frame of " + std::to_string(frame.cols) + "x" + std::to_string(frame.rows) + " pixels of " +
                std::to_string(frame.bits_allocated) + " bits cannot be decoded (expected 8, 16 or 32 bits)");
}

// The bytes OpenJPEG reads, through the callbacks below: never past the end.
struct MemoryStream {
  Bytes data;
  std::size_t pos = 0;
};

OPJ_SIZE_T read_memory(void* dst, OPJ_SIZE_T n, void* user) {
  auto& m = *static_cast<MemoryStream*>(user);
  if (m.pos >= m.data.size()) return static_cast<OPJ_SIZE_T>(-1);  // the end of the stream
  const std::size_t count = std::min<std::size_t>(n, m.data.size() - m.pos);
  std::memcpy(dst, m.data.data() + m.pos, count);
  m.pos += count;
  return count;
}

OPJ_OFF_T skip_memory(OPJ_OFF_T n, void* user) {
  auto& m = *static_cast<MemoryStream*>(user);
  if (n < 0) {
    if (n == std::numeric_limits<OPJ_OFF_T>::min() || static_cast<std::uint64_t>(-n) > m.pos) return -1;
    m.pos -= static_cast<std::size_t>(-n);
  } else {
    if (static_cast<std::uint64_t>(n) > m.data.size() - m.pos) return -1;
    m.pos += static_cast<std::size_t>(n);
  }
  return n;
}

OPJ_BOOL seek_memory(OPJ_OFF_T to, void* user) {
  auto& m = *static_cast<MemoryStream*>(user);
  if (to < 0 || static_cast<std::uint64_t>(to) > m.data.size()) return OPJ_FALSE;
  m.pos = static_cast<std::size_t>(to);
  return OPJ_TRUE;
}

// OpenJPEG's error and warning messages, kept (user: a std::string) for the Error a failure gives.
void keep_message(const char* message, void* user) {
  try {
    auto& kept = *static_cast<std::string*>(user);
    const std::string text = printable(trim(message ? message : ""), 200);
    if (text.empty() || kept.size() >= kMaxMessageChars) return;
    kept += (kept.empty() ? "" : "; ") + text;
  } catch (...) {  // nothing may leave a callback into C
  }
}

void ignore_message(const char*, void*) {}

struct StreamFree {
  void operator()(opj_stream_t* s) const { opj_stream_destroy(s); }
};
struct CodecFree {
  void operator()(opj_codec_t* c) const { opj_destroy_codec(c); }
};
struct ImageFree {
  void operator()(opj_image_t* i) const { opj_image_destroy(i); }
};

// Stores the decoded values as unsigned integers U of BitsAllocated bits (see decode_jpeg2000).
template <class U>
void store(const OPJ_INT32* src, const Jpeg2000Frame& frame, bool codestream_signed, std::span<char> out) {
  using S = std::make_signed_t<U>;
  const bool both_signed = frame.is_signed && codestream_signed;
  const std::int64_t lo = both_signed ? std::numeric_limits<S>::min() : 0;
  const std::int64_t hi = both_signed ? std::int64_t{std::numeric_limits<S>::max()} : std::int64_t{std::numeric_limits<U>::max()};
  const std::size_t pixels = static_cast<std::size_t>(frame.rows) * static_cast<std::size_t>(frame.cols);
  for (std::size_t i = 0; i < pixels; ++i) {
    const std::int64_t v = src[i];
    if (v < lo || v > hi) {
      const std::string at = " at row " + std::to_string(i / static_cast<std::size_t>(frame.cols)) + ", column " +
                             std::to_string(i % static_cast<std::size_t>(frame.cols));
      if (v < 0 && !frame.is_signed)
        throw Error("JPEG 2000 value " + std::to_string(v) + at + " is negative, but PixelRepresentation is 0 (unsigned values)");
      throw Error("JPEG 2000 value " + std::to_string(v) + at + " does not fit BitsAllocated (" + std::to_string(frame.bits_allocated) + ")");
    }
    const U u = static_cast<U>(v);  // a negative value as its two's complement
    std::memcpy(out.data() + i * sizeof(U), &u, sizeof(U));
  }
}

}  // namespace

void check_jpeg2000_header(std::span<const unsigned char> data, const Jpeg2000Frame& frame) {
  check_frame(frame);
  (void)read_siz(codestream_of(data), frame);
}

void decode_jpeg2000(std::span<const unsigned char> data, const Jpeg2000Frame& frame, std::span<char> out) {
  check_frame(frame);
  const std::size_t pixels = static_cast<std::size_t>(frame.rows) * static_cast<std::size_t>(frame.cols);
  if (out.size() != pixels * static_cast<std::size_t>(frame.bits_allocated / 8))
    throw Error("JPEG 2000 frame decoded into " + bytes_str(out.size()) + " (expected " +
                bytes_str(pixels * static_cast<std::size_t>(frame.bits_allocated / 8)) + ")");
  MemoryStream memory{codestream_of(data)};
  const Siz siz = read_siz(memory.data, frame);

  std::string errors, warnings;
  auto failed = [&](const std::string& step) {
    std::string what = "OpenJPEG failed " + step;
    if (!errors.empty()) what += ": " + errors;
    if (!warnings.empty()) what += " (warnings: " + warnings + ")";
    return Error(what);
  };
  // Declared after `memory`, which they read: freed before it, on every path.
  const std::unique_ptr<opj_stream_t, StreamFree> stream(
      opj_stream_create(std::clamp<std::size_t>(memory.data.size(), 1, std::size_t{1} << 20), OPJ_STREAM_READ));
  if (!stream) throw Error("OpenJPEG could not create a stream");
  opj_stream_set_read_function(stream.get(), read_memory);
  opj_stream_set_skip_function(stream.get(), skip_memory);
  opj_stream_set_seek_function(stream.get(), seek_memory);
  opj_stream_set_user_data(stream.get(), &memory, nullptr);
  opj_stream_set_user_data_length(stream.get(), memory.data.size());
  const std::unique_ptr<opj_codec_t, CodecFree> codec(opj_create_decompress(OPJ_CODEC_J2K));
  if (!codec) throw Error("OpenJPEG could not create a decoder");
  opj_set_error_handler(codec.get(), keep_message, &errors);
  opj_set_warning_handler(codec.get(), keep_message, &warnings);
  opj_set_info_handler(codec.get(), ignore_message, nullptr);
  opj_dparameters_t parameters;
  opj_set_default_decoder_parameters(&parameters);
  if (!opj_setup_decoder(codec.get(), &parameters)) throw failed("setting up the decoder");
  if (!opj_decoder_set_strict_mode(codec.get(), OPJ_TRUE)) throw failed("setting strict decoding");  // a truncated codestream is an error

  opj_image_t* header_image = nullptr;
  const bool header_read = opj_read_header(stream.get(), codec.get(), &header_image) != 0;
  const std::unique_ptr<opj_image_t, ImageFree> image(header_image);
  if (!header_read || !image) throw failed("reading the main header");
  if (image->numcomps != 1 || !image->comps || image->x1 - image->x0 != static_cast<OPJ_UINT32>(frame.cols) ||
      image->y1 - image->y0 != static_cast<OPJ_UINT32>(frame.rows))
    throw Error("OpenJPEG reads a header of " + std::to_string(image->numcomps) + " components over " + std::to_string(image->x1 - image->x0) +
                "x" + std::to_string(image->y1 - image->y0) + " pixels (expected the SIZ marker segment's 1 over " +
                std::to_string(frame.cols) + "x" + std::to_string(frame.rows) + ")");
  if (!opj_decode(codec.get(), stream.get(), image.get())) throw failed("decoding the codestream");
  if (!opj_end_decompress(codec.get(), stream.get())) throw failed("reading the end of the codestream");

  if (image->numcomps != 1 || !image->comps) throw Error("OpenJPEG decoded " + std::to_string(image->numcomps) + " components (expected 1)");
  const opj_image_comp_t& c = image->comps[0];
  if (!c.data) throw Error("OpenJPEG decoded no values");
  if (c.w != static_cast<OPJ_UINT32>(frame.cols) || c.h != static_cast<OPJ_UINT32>(frame.rows) || c.factor != 0)
    throw Error("OpenJPEG decoded " + std::to_string(c.w) + "x" + std::to_string(c.h) + " values (expected " + std::to_string(frame.cols) +
                "x" + std::to_string(frame.rows) + ", as Columns and Rows say)");
  if (c.prec != siz.precision || (c.sgnd != 0) != siz.is_signed)
    throw Error("OpenJPEG decoded " + std::to_string(c.prec) + "-bit " + (c.sgnd ? "signed" : "unsigned") + " values (expected the header's " +
                std::to_string(siz.precision) + "-bit " + (siz.is_signed ? "signed" : "unsigned") + " ones)");
  switch (frame.bits_allocated) {
    case 8: return store<std::uint8_t>(c.data, frame, siz.is_signed, out);
    case 16: return store<std::uint16_t>(c.data, frame, siz.is_signed, out);
    default: return store<std::uint32_t>(c.data, frame, siz.is_signed, out);
  }
}

}  // namespace penumbra::io_detail
