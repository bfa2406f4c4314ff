// One DICOM slice file, walked and checked element by element (dicom_slice.cpp; dicom_loader.cpp says
// why GDCM never parses a file) and the attributes that place and scale it; the byte ranges of its
// pixel data. Internal to the DICOM reader (dicom_loader.cpp, dicom_series.h, dicom_pixels.h).
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/data/io/jpeg2000_decode.h"

namespace penumbra::dicom {

constexpr std::uint32_t tag(std::uint16_t group, std::uint16_t element) {
  return static_cast<std::uint32_t>(group) << 16 | element;
}
constexpr std::uint32_t kPosition = tag(0x0020, 0x0032);

enum class Codec { None, Rle, Jpeg, Jpeg2000 };  // Jpeg: JPEG and JPEG-LS (the same marker syntax)

struct TransferSyntax {
  const char* uid;
  const char* name;
  bool implicit_vr, big_endian;
  Codec codec;
  bool lossy;
};

// One slice file, with the attributes that place and scale it.
struct Slice {
  std::string path, name;  // name: how messages call it (the file name in a folder, the path in a list)
  std::string series_uid, description, modality, photometric;
  std::optional<long> series_number;
  const TransferSyntax* syntax = nullptr;
  int rows = 0, cols = 0, bits_allocated = 0, bits_stored = 0;
  bool is_signed = false;
  std::optional<std::array<double, 3>> position;
  std::optional<std::array<double, 6>> orientation;
  std::optional<std::array<double, 2>> pixel_spacing;  // (between rows, between columns) = (y, x)
  std::optional<double> thickness;
  double slope = 1, intercept = 0;
  std::vector<std::pair<std::uint64_t, std::uint32_t>> fragments;  // the pixel data (Header::fragments)
};

// "(GGGG,EEEE)"
std::string tag_str(std::uint32_t t);
// A number as the file would write it: the shortest text that reads back exactly (1.07421875, 277.91).
std::string dec(double v);
// Bytes [offset, offset + length) of the file.
std::vector<unsigned char> read_bytes(const std::string& path, std::pair<std::uint64_t, std::uint32_t> range);
// What OpenJPEG needs to know of a JPEG 2000 slice, and the slice's compressed frame (its fragments
// concatenated).
io_detail::Jpeg2000Frame jpeg2000_frame(const Slice& s);
std::vector<unsigned char> read_frame(const Slice& s);
// The slice in `path` (messages call it `name`); with `skip_non_images`, nullopt for a file that is no
// DICOM image (a folder's other files), else Error naming the file.
std::optional<Slice> read_slice(const std::string& path, const std::string& name, bool skip_non_images);

}  // namespace penumbra::dicom
