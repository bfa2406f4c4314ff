#include "penumbra/data/io/dicom_pixels.h"

#include <gdcmImage.h>
#include <gdcmSequenceOfFragments.h>

#include <algorithm>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/text_fields.h"

namespace penumbra::dicom {
namespace {

using io_detail::bytes_str;
using io_detail::printable;

// The stored values of one slice in host byte order (bits above BitsStored are dealt with by fill).
// Native pixel data is read here and RLE decoded here. JPEG and JPEG-LS go to GDCM's codecs as an image
// assembled from the checked attributes and the fragments found by the walk: GDCM never parses the file
// itself, whose other attributes (spacings, sequences) it reads with asserts. JPEG 2000 goes to
// OpenJPEG (jpeg2000_decode.h), the frame's fragments concatenated.
void decode_rle(const Slice& s, std::vector<char>& buffer);

void decode_jpeg2000(const Slice& s, std::vector<char>& buffer) {
  const std::vector<unsigned char> data = read_frame(s);
  buffer.resize(static_cast<std::size_t>(s.rows) * s.cols * (s.bits_allocated / 8));
  io_detail::decode_jpeg2000(data, jpeg2000_frame(s), buffer);
}

void decode_native(const Slice& s, std::vector<char>& buffer) {
  const std::size_t bytes_per_pixel = static_cast<std::size_t>(s.bits_allocated / 8);
  const std::size_t bytes = static_cast<std::size_t>(s.rows) * s.cols * bytes_per_pixel;
  const std::vector<unsigned char> data = read_bytes(s.path, {s.fragments.at(0).first, static_cast<std::uint32_t>(bytes)});
  buffer.assign(data.begin(), data.end());
  if (s.syntax->big_endian && bytes_per_pixel > 1)
    for (std::size_t p = 0; p < bytes; p += bytes_per_pixel) std::reverse(buffer.begin() + static_cast<std::ptrdiff_t>(p),
                                                                          buffer.begin() + static_cast<std::ptrdiff_t>(p + bytes_per_pixel));
}

void decode_jpeg(const Slice& s, std::vector<char>& buffer) {
  gdcm::Image image;
  image.SetNumberOfDimensions(2);
  image.SetDimension(0, static_cast<unsigned>(s.cols));
  image.SetDimension(1, static_cast<unsigned>(s.rows));
  image.SetPixelFormat(gdcm::PixelFormat(1, static_cast<unsigned short>(s.bits_allocated), static_cast<unsigned short>(s.bits_stored),
                                         static_cast<unsigned short>(s.bits_stored - 1), s.is_signed ? 1 : 0));  // HighBit: checked
  image.SetPhotometricInterpretation(gdcm::PhotometricInterpretation::MONOCHROME2);
  image.SetTransferSyntax(gdcm::TransferSyntax::GetTSType(s.syntax->uid));
  gdcm::SmartPointer<gdcm::SequenceOfFragments> fragments = new gdcm::SequenceOfFragments;
  for (const auto& range : s.fragments) {
    const std::vector<unsigned char> bytes = read_bytes(s.path, range);
    gdcm::Fragment fragment;
    fragment.SetByteValue(reinterpret_cast<const char*>(bytes.data()), static_cast<std::uint32_t>(bytes.size()));
    fragments->AddFragment(fragment);
  }
  gdcm::DataElement pixels(gdcm::Tag(0x7FE0, 0x0010));
  pixels.SetVR(gdcm::VR::OB);
  pixels.SetValue(*fragments);
  image.SetDataElement(pixels);
  const std::size_t bytes = static_cast<std::size_t>(s.rows) * s.cols * (s.bits_allocated / 8);
  if (image.GetBufferLength() != bytes) throw Error("GDCM gives " + bytes_str(image.GetBufferLength()) + " of pixels, expected " + bytes_str(bytes));
  buffer.resize(bytes);
  if (!image.GetBuffer(buffer.data())) throw Error(std::string("GDCM could not decode the pixel data (") + s.syntax->name + ")");
}

void decode(const Slice& s, std::vector<char>& buffer) {
  with_context(s.name, [&] {
    try {
      switch (s.syntax->codec) {
        case Codec::None: return decode_native(s, buffer);
        case Codec::Rle: return decode_rle(s, buffer);
        case Codec::Jpeg: return decode_jpeg(s, buffer);
        case Codec::Jpeg2000: return decode_jpeg2000(s, buffer);
      }
    } catch (const Error&) {
      throw;
    } catch (const std::exception& e) {
      throw Error(std::string(s.syntax->codec == Codec::Jpeg ? "GDCM failed" : "failed") + " decoding the pixel data (" + printable(e.what()) + ")");
    } catch (...) {
      throw Error(std::string(s.syntax->codec == Codec::Jpeg ? "GDCM failed" : "failed") + " decoding the pixel data");
    }
  });
}

// RLE Lossless (DICOM PS3.5 annex G), decoded here: GDCM's RLE decoder asserts, divides by zero or
// reads out of bounds on a corrupt header or segment (and runs even while just reading the file).
// One segment per byte of a pixel, the most significant first, each PackBits-coded.
void decode_rle(const Slice& s, std::vector<char>& buffer) {
  const std::vector<unsigned char> data = read_frame(s);
  auto u32 = [&](std::size_t i) { return std::uint64_t{data[i]} | std::uint64_t{data[i + 1]} << 8 | std::uint64_t{data[i + 2]} << 16 | std::uint64_t{data[i + 3]} << 24; };
  const std::size_t pixels = static_cast<std::size_t>(s.rows) * s.cols, planes = static_cast<std::size_t>(s.bits_allocated / 8);
  if (data.size() < 64) throw Error("RLE data of " + bytes_str(data.size()) + " (expected at least its 64-byte header)");
  if (u32(0) != planes)
    throw Error("RLE header has " + std::to_string(u32(0)) + " segments, expected " + std::to_string(planes) + " (one per byte of a pixel)");
  buffer.assign(pixels * planes, 0);
  for (std::size_t seg = 0; seg < planes; ++seg) {
    const std::uint64_t begin = u32(4 + 4 * seg), end = seg + 1 < planes ? u32(8 + 4 * seg) : data.size();
    if (begin < 64 || begin > end || end > data.size())
      throw Error("RLE segment " + std::to_string(seg + 1) + " at bytes " + std::to_string(begin) + ".." + std::to_string(end) +
                  " is outside the " + bytes_str(data.size()) + " of data");
    char* out = buffer.data() + (planes - 1 - seg);  // this byte of each little-endian pixel
    std::size_t in = begin, n = 0;
    while (n < pixels) {
      if (in >= end) throw Error("RLE segment " + std::to_string(seg + 1) + " ends after " + std::to_string(n) + " of its " + std::to_string(pixels) + " bytes");
      const int code = static_cast<signed char>(data[in++]);
      if (code >= 0) {  // code + 1 literal bytes
        const std::size_t count = std::min<std::size_t>(static_cast<std::size_t>(code) + 1, std::min<std::size_t>(end - in, pixels - n));
        for (std::size_t k = 0; k < count; ++k) out[(n + k) * planes] = static_cast<char>(data[in + k]);
        in += static_cast<std::size_t>(code) + 1;
        n += count;
      } else if (code != -128) {  // 1 - code copies of the next byte
        if (in >= end) break;
        const std::size_t count = std::min<std::size_t>(static_cast<std::size_t>(1 - code), pixels - n);
        for (std::size_t k = 0; k < count; ++k) out[(n + k) * planes] = static_cast<char>(data[in]);
        ++in;
        n += count;
      }
    }
  }
}

// Calls f with the unsigned integer type of a stored pixel's BitsAllocated.
template <class F>
decltype(auto) with_stored_type(const Slice& s, F&& f) {
  switch (s.bits_allocated) {
    case 8: return f(std::uint8_t{});
    case 16: return f(std::uint16_t{});
    default: return f(std::uint32_t{});
  }
}

// Decodes every slice into `volume` (of type T), rescaled. False when T is an integer type and a
// rescaled value does not fit it (the caller then uses float32).
template <class T>
bool fill_as(Volume& volume, const Layout& L) {
  T* dst = volume.data_as<T>();
  std::vector<char> buffer;
  for (std::size_t k = 0; k < L.slices.size(); ++k) {
    const Slice& s = *L.slices[k];
    decode(s, buffer);
    const bool ok = with_stored_type(s, [&](auto stored) {
      using S = decltype(stored);
      const auto slope = static_cast<std::int64_t>(s.slope), intercept = static_cast<std::int64_t>(s.intercept);
      // Bits above BitsStored are masked off, or copies of the sign bit (GDCM does the same; the RLE and
      // JPEG 2000 paths do not go through GDCM). So a signed image whose JPEG 2000 codestream holds the
      // stored bit patterns as unsigned values comes out signed here.
      const std::uint64_t mask = (std::uint64_t{1} << s.bits_stored) - 1;
      const std::uint64_t sign = std::uint64_t{1} << (s.bits_stored - 1);
      for (int j = 0; j < s.rows; ++j) {
        const char* src = buffer.data() + static_cast<std::size_t>(j) * s.cols * sizeof(S);
        T* out = dst + L.slice[k] + L.row[static_cast<std::size_t>(j)];
        for (int i = 0; i < s.cols; ++i) {
          S raw;
          std::memcpy(&raw, src + static_cast<std::size_t>(i) * sizeof(S), sizeof(S));
          const std::uint64_t bits = raw & mask;
          const std::int64_t v = s.is_signed && (bits & sign) ? static_cast<std::int64_t>(bits) - static_cast<std::int64_t>(mask) - 1
                                                               : static_cast<std::int64_t>(bits);
          if constexpr (std::is_integral_v<T>) {
            const std::int64_t x = v * slope + intercept;
            if (x < std::numeric_limits<T>::min() || x > std::numeric_limits<T>::max()) return false;
            out[L.col[static_cast<std::size_t>(i)]] = static_cast<T>(x);
          } else {
            out[L.col[static_cast<std::size_t>(i)]] = static_cast<T>(static_cast<double>(v) * s.slope + s.intercept);
          }
        }
      }
      return true;
    });
    if (!ok) return false;
  }
  return true;
}

}  // namespace

bool fill_slices(Volume& volume, const Layout& L) {
  return volume.with_voxel_type([&](auto t) { return fill_as<decltype(t)>(volume, L); });
}

}  // namespace penumbra::dicom
