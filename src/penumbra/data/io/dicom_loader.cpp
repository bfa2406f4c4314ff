// DICOM series (a folder of slices or a list of slice files). GDCM trusts the lengths in a file (a
// corrupt length makes it allocate and zero up to 4 GB) and asserts on malformed attributes, so GDCM
// never parses a file: every file is walked here (its elements, sequences and pixel-data fragments must
// nest properly and fit in the file) and the attributes the volume needs are read on the way. Native
// pixel data is then read here and RLE decoded here (GDCM's RLE decoder asserts or reads out of bounds
// on corrupt segments); only JPEG and JPEG-LS fragments go to GDCM's codecs, in an image assembled from
// the checked attributes, after the codestream's header has been checked against Rows and Columns.
// JPEG 2000 fragments go to OpenJPEG directly (jpeg2000_decode.h), not to GDCM's JPEG 2000 codec, after
// the same check of their header. Slices are grouped by SeriesInstanceUID, sorted by
// ImagePositionPatient along the slice normal and checked to be evenly spaced; the rescale is applied
// per slice. An axis-aligned series is permuted and flipped so that the volume's axes are patient +x,
// +y, +z (LPS); an oblique one keeps its grid, without its rotation.
#include <gdcmDicts.h>
#include <gdcmGlobal.h>
#include <gdcmImage.h>
#include <gdcmSequenceOfFragments.h>
#include <gdcmTrace.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <type_traits>
#include <vector>

#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/jpeg2000_decode.h"
#include "penumbra/data/io/text_fields.h"
#include "penumbra/data/io/volume_io.h"

namespace penumbra {

namespace {

using io_detail::bytes_str;
using io_detail::printable;

constexpr std::uint32_t tag(std::uint16_t group, std::uint16_t element) {
  return static_cast<std::uint32_t>(group) << 16 | element;
}

constexpr std::uint32_t kTransferSyntaxUid = tag(0x0002, 0x0010);
constexpr std::uint32_t kModality = tag(0x0008, 0x0060);
constexpr std::uint32_t kSeriesDescription = tag(0x0008, 0x103E);
constexpr std::uint32_t kSliceThickness = tag(0x0018, 0x0050);
constexpr std::uint32_t kSeriesUid = tag(0x0020, 0x000E);
constexpr std::uint32_t kSeriesNumber = tag(0x0020, 0x0011);
constexpr std::uint32_t kPosition = tag(0x0020, 0x0032);
constexpr std::uint32_t kOrientation = tag(0x0020, 0x0037);
constexpr std::uint32_t kSamplesPerPixel = tag(0x0028, 0x0002);
constexpr std::uint32_t kPhotometric = tag(0x0028, 0x0004);
constexpr std::uint32_t kNumberOfFrames = tag(0x0028, 0x0008);
constexpr std::uint32_t kRows = tag(0x0028, 0x0010);
constexpr std::uint32_t kColumns = tag(0x0028, 0x0011);
constexpr std::uint32_t kPixelSpacing = tag(0x0028, 0x0030);
constexpr std::uint32_t kBitsAllocated = tag(0x0028, 0x0100);
constexpr std::uint32_t kBitsStored = tag(0x0028, 0x0101);
constexpr std::uint32_t kHighBit = tag(0x0028, 0x0102);
constexpr std::uint32_t kPixelRepresentation = tag(0x0028, 0x0103);
constexpr std::uint32_t kRescaleIntercept = tag(0x0028, 0x1052);
constexpr std::uint32_t kRescaleSlope = tag(0x0028, 0x1053);
constexpr std::uint32_t kPixelData = tag(0x7FE0, 0x0010);

const std::set<std::uint32_t> kWanted = {kModality, kSeriesDescription, kSliceThickness, kSeriesUid, kSeriesNumber,
                                         kPosition, kOrientation, kSamplesPerPixel, kPhotometric, kNumberOfFrames,
                                         kRows, kColumns, kPixelSpacing, kBitsAllocated, kBitsStored, kHighBit,
                                         kPixelRepresentation, kRescaleIntercept, kRescaleSlope};

constexpr std::uint32_t kUndefinedLength = 0xFFFFFFFF;
constexpr std::size_t kMaxNesting = 32;           // sequences within sequences (GDCM reads them recursively)
constexpr std::uint32_t kMaxValueBytes = 4096;    // of an attribute read here (all are short strings or numbers)
// Decoded pixels per byte of compressed pixel data at most: above any real image (a blank 512x512
// slice in JPEG-LS takes a few hundred bytes), and it keeps a tiny file from making the
// codec allocate gigabytes.
constexpr std::uint64_t kMaxCompressionRatio = 10000;

enum class Codec { None, Rle, Jpeg, Jpeg2000 };  // Jpeg: JPEG and JPEG-LS (the same marker syntax)

struct TransferSyntax {
  const char* uid;
  const char* name;
  bool implicit_vr, big_endian;
  Codec codec;
  bool lossy;
};

// What is decoded: JPEG and JPEG-LS by GDCM (Debian's build: IJG JPEG, CharLS), RLE here, JPEG 2000 by
// OpenJPEG called from here (jpeg2000_decode.cpp). Not by GDCM's JPEG 2000 codec: it read out of bounds
// on corrupt codestreams (found by fuzz_dicom, depending on the state of memory, so no check of the
// header ahead of it could rule it out). The JPEG 2000 Part 2 multi-component syntaxes (.92, .93) and
// High-Throughput JPEG 2000 are not read.
constexpr TransferSyntax kTransferSyntaxes[] = {
    {"1.2.840.10008.1.2", "Implicit VR Little Endian", true, false, Codec::None, false},
    {"1.2.840.10008.1.2.1", "Explicit VR Little Endian", false, false, Codec::None, false},
    {"1.2.840.10008.1.2.2", "Explicit VR Big Endian", false, true, Codec::None, false},
    {"1.2.840.10008.1.2.5", "RLE Lossless", false, false, Codec::Rle, false},
    {"1.2.840.10008.1.2.4.50", "JPEG Baseline", false, false, Codec::Jpeg, true},
    {"1.2.840.10008.1.2.4.51", "JPEG Extended", false, false, Codec::Jpeg, true},
    {"1.2.840.10008.1.2.4.57", "JPEG Lossless", false, false, Codec::Jpeg, false},
    {"1.2.840.10008.1.2.4.70", "JPEG Lossless SV1", false, false, Codec::Jpeg, false},
    {"1.2.840.10008.1.2.4.80", "JPEG-LS Lossless", false, false, Codec::Jpeg, false},
    {"1.2.840.10008.1.2.4.81", "JPEG-LS Near-Lossless", false, false, Codec::Jpeg, true},
    {"1.2.840.10008.1.2.4.90", "JPEG 2000 Lossless", false, false, Codec::Jpeg2000, false},
    {"1.2.840.10008.1.2.4.91", "JPEG 2000", false, false, Codec::Jpeg2000, true},  // lossless or lossy
};

const TransferSyntax* find_syntax(const std::string& uid) {
  for (const TransferSyntax& ts : kTransferSyntaxes)
    if (uid == ts.uid) return &ts;
  return nullptr;
}

std::string tag_str(std::uint32_t t) {
  char s[16];
  std::snprintf(s, sizeof s, "(%04X,%04X)", t >> 16, t & 0xFFFF);
  return s;
}

// A number as the file would write it: the shortest text that reads back exactly (1.07421875, 277.91).
std::string dec(double v) {
  char s[32];
  return std::string(s, std::to_chars(s, s + sizeof s, v).ptr);
}

bool is_vr(const char* v) {
  static const std::set<std::string> vrs = {"AE", "AS", "AT", "CS", "DA", "DS", "DT", "FD", "FL", "IS", "LO", "LT",
                                            "OB", "OD", "OF", "OL", "OV", "OW", "PN", "SH", "SL", "SQ", "SS", "ST",
                                            "SV", "TM", "UC", "UI", "UL", "UN", "UR", "US", "UT", "UV"};
  return vrs.count(std::string(v, 2)) > 0;
}

// VRs whose explicit element header has 2 reserved bytes and a 4-byte length.
bool has_long_length(const char* v) {
  static const std::set<std::string> vrs = {"OB", "OD", "OF", "OL", "OV", "OW", "SQ", "SV", "UC", "UN", "UR", "UT", "UV"};
  return vrs.count(std::string(v, 2)) > 0;
}

// GDCM reads the image attributes with gdcm::Attribute, which asserts (aborts) when an element's VR
// does not match the dictionary's, or a one-valued US/SS element is not 2 bytes long. Both are checked
// here for every element of the dictionary. An explicit UN is accepted (tools write it for tags they do
// not know) except in group 0028, the image attributes.
void check_against_dictionary(std::uint32_t t, const char* file_vr, std::uint32_t len) {
  const gdcm::DictEntry& entry = gdcm::Global::GetInstance().GetDicts().GetDictEntry(gdcm::Tag(static_cast<std::uint16_t>(t >> 16), static_cast<std::uint16_t>(t)));
  const gdcm::VR dict_vr = entry.GetVR();
  if (dict_vr == gdcm::VR::INVALID || t >> 16 == 0xFFFE) return;
  if (file_vr) {
    const gdcm::VR vr(gdcm::VR::GetVRTypeFromFile(file_vr));
    if (!(dict_vr.Compatible(vr) || (vr == gdcm::VR::UN && t >> 16 != 0x0028)))
      throw Error("element " + tag_str(t) + " has VR " + std::string(file_vr, 2) + ", expected " + gdcm::VR::GetVRString(dict_vr));
  }
  if ((dict_vr == gdcm::VR::US || dict_vr == gdcm::VR::SS || dict_vr == gdcm::VR::US_SS) && entry.GetVM() == gdcm::VM::VM1 && len != 2 &&
      !(file_vr && gdcm::VR(gdcm::VR::GetVRTypeFromFile(file_vr)) == gdcm::VR::UN))
    throw Error("element " + tag_str(t) + " is " + bytes_str(len) + " long, expected one 2-byte value");
}

// Sequential reads from a file, each checked against what is left of it.
class FileBytes {
public:
  explicit FileBytes(const std::string& path) : in_(path, std::ios::binary), size_(io_detail::regular_file_size(path)) {
    if (!in_) throw Error("cannot open the file");
  }
  std::uint64_t pos() const { return pos_; }
  std::uint64_t left() const { return size_ - pos_; }
  void read(void* dst, std::uint64_t n) {
    if (n > left()) throw Error("truncated file: " + bytes_str(n) + " needed at byte " + std::to_string(pos_) + ", " + bytes_str(left()) + " left");
    if (stream_pos_ != pos_) in_.seekg(static_cast<std::streamoff>(pos_));  // a seek drops the stream's buffer
    if (!in_.read(static_cast<char*>(dst), static_cast<std::streamsize>(n))) throw Error("cannot read the file");
    stream_pos_ = pos_ += n;
  }
  void skip(std::uint64_t n) { pos_ += n; }  // n checked by the caller
  void seek(std::uint64_t pos) { pos_ = pos; }
  std::uint16_t u16(bool big_endian) {
    unsigned char b[2];
    read(b, 2);
    return static_cast<std::uint16_t>(big_endian ? b[0] << 8 | b[1] : b[1] << 8 | b[0]);
  }
  std::uint32_t u32(bool big_endian) {
    const std::uint32_t a = u16(big_endian), b = u16(big_endian);
    return big_endian ? a << 16 | b : b << 16 | a;
  }

private:
  std::ifstream in_;
  std::uint64_t size_;
  std::uint64_t pos_ = 0, stream_pos_ = 0;
};

// What the walk over a file found: the attributes of kWanted at the top level and the pixel data.
struct Header {
  bool marker = false;                       // "DICM" at byte 128
  std::string syntax_uid;                    // from the file meta; "" when there is none
  const TransferSyntax* syntax = nullptr;    // null when not one GDCM decodes (then nothing else is read)
  std::map<std::uint32_t, std::string> values;
  bool has_pixel_data = false, encapsulated = false;
  std::uint64_t pixel_bytes = 0;             // the value length, or the sum of the fragments
  // offset and length of the native pixel data, or of each fragment after the offset table
  std::vector<std::pair<std::uint64_t, std::uint32_t>> fragments;
  bool offset_table_seen = false;
};

// Walks every element of the file into `h` (see the top of this file). Throws Error on anything
// malformed; h.marker is set first, so that a caller can tell a broken DICOM file from another file.
void walk_file(const std::string& path, Header& h) {
  FileBytes f(path);
  if (f.left() >= 132) {
    char magic[4];
    f.seek(128);
    f.read(magic, 4);
    h.marker = std::memcmp(magic, "DICM", 4) == 0;
    if (!h.marker) f.seek(0);
  }
  // File meta information: explicit VR little endian, group 0002.
  while (f.left() >= 8) {
    const std::uint64_t start = f.pos();
    if (f.u16(false) != 0x0002) {
      f.seek(start);
      break;
    }
    const std::uint32_t t = tag(0x0002, f.u16(false));
    char vr[2];
    f.read(vr, 2);
    if (!is_vr(vr)) throw Error("file meta element " + tag_str(t) + " has no valid VR");
    std::uint32_t len = f.u16(false);
    if (has_long_length(vr)) len = f.u32(false);  // after 2 reserved bytes
    if (len > f.left())
      throw Error("file meta element " + tag_str(t) + " claims " + bytes_str(len) + ", the file has " + bytes_str(f.left()) + " left");
    if (t == kTransferSyntaxUid && len <= 64) {
      std::string uid(len, '\0');
      f.read(uid.data(), len);
      h.syntax_uid = std::string(io_detail::trim(uid.c_str()));
    } else {
      f.skip(len);
    }
  }
  bool implicit = true, big_endian = false;
  if (!h.syntax_uid.empty()) {
    h.syntax = find_syntax(h.syntax_uid);
    if (!h.syntax) return;
    implicit = h.syntax->implicit_vr;
    big_endian = h.syntax->big_endian;
  } else {
    // No file meta: a bare data set in implicit or explicit VR little endian (GDCM guesses the same
    // way). It must start with an element of group 0008, or the file is not taken for DICOM.
    const std::uint64_t start = f.pos();
    unsigned char b[6] = {};
    if (f.left() < 8) throw Error("not a DICOM file (too short)");
    f.read(b, 6);
    if (b[0] != 0x08 || b[1] != 0x00)
      throw Error(h.marker ? "no file meta information and no data set after the DICM marker"
                           : "not a DICOM file (no DICM marker at byte 128 and no DICOM data set at the start)");
    implicit = !is_vr(reinterpret_cast<const char*>(b + 4));
    h.syntax = find_syntax(implicit ? "1.2.840.10008.1.2" : "1.2.840.10008.1.2.1");
    f.seek(start);
  }

  struct Frame {
    enum Kind { Item, Sequence, Fragments } kind;
    std::uint64_t end;  // max() for an undefined length (ended by a delimiter)
    bool implicit;
  };
  constexpr std::uint64_t kOpen = std::numeric_limits<std::uint64_t>::max();
  std::vector<Frame> stack;
  auto fits = [&](std::uint32_t len, std::uint32_t t) {
    const std::uint64_t room = stack.empty() || stack.back().end == kOpen ? f.left() : stack.back().end - f.pos();
    if (len > std::min(room, f.left()))
      throw Error("element " + tag_str(t) + " at byte " + std::to_string(f.pos()) + " claims " + bytes_str(len) + " but only " +
                  bytes_str(std::min(room, f.left())) + " remain" + (room < f.left() ? " in its item" : " in the file") +
                  " (truncated or corrupt file)");
  };
  auto push = [&](Frame frame) {
    if (stack.size() == kMaxNesting) throw Error("sequences nested more than " + std::to_string(kMaxNesting) + " deep");
    stack.push_back(frame);
  };
  for (;;) {
    while (!stack.empty() && stack.back().end != kOpen && stack.back().end <= f.pos()) {
      if (stack.back().end < f.pos()) throw Error("an element header crosses the end of its item at byte " + std::to_string(stack.back().end));
      stack.pop_back();
    }
    if (f.left() == 0) break;
    const bool in_items = !stack.empty() && stack.back().kind != Frame::Item;
    const bool vr_implicit = stack.empty() ? implicit : stack.back().implicit;
    const std::uint16_t group = f.u16(big_endian);
    const std::uint32_t t = tag(group, f.u16(big_endian));
    if (group == 0xFFFE) {
      const std::uint32_t len = f.u32(big_endian);
      if (t == tag(0xFFFE, 0xE000) && in_items) {
        if (stack.back().kind == Frame::Fragments) {
          if (len == kUndefinedLength) throw Error("a pixel data fragment of undefined length");
          fits(len, t);
          if (h.offset_table_seen) h.fragments.push_back({f.pos(), len});
          h.offset_table_seen = true;
          f.skip(len);
          h.pixel_bytes += len;
        } else {
          if (len != kUndefinedLength) fits(len, t);
          push({Frame::Item, len == kUndefinedLength ? kOpen : f.pos() + len, stack.back().implicit});
        }
      } else if (len == 0 && !stack.empty() && stack.back().end == kOpen &&
                 ((t == tag(0xFFFE, 0xE00D) && !in_items) || (t == tag(0xFFFE, 0xE0DD) && in_items))) {
        stack.pop_back();
      } else {
        throw Error("unexpected item or delimiter " + tag_str(t) + " at byte " + std::to_string(f.pos() - 8));
      }
      continue;
    }
    if (in_items) throw Error("element " + tag_str(t) + " at byte " + std::to_string(f.pos() - 4) + " where a sequence item was expected");
    char vr[3] = "UN";
    std::uint32_t len = 0;
    if (vr_implicit) {
      len = f.u32(big_endian);
    } else {
      f.read(vr, 2);
      if (!is_vr(vr)) throw Error("element " + tag_str(t) + " at byte " + std::to_string(f.pos() - 6) + " has no valid VR ('" + printable(std::string_view(vr, 2)) + "')");
      if (has_long_length(vr)) {
        f.u16(big_endian);
        len = f.u32(big_endian);
      } else {
        len = f.u16(big_endian);
      }
    }
    const std::string_view v(vr, 2);
    if (len == kUndefinedLength) {
      if (t == kPixelData && stack.empty() && (v == "OB" || v == "OW")) {
        h.has_pixel_data = h.encapsulated = true;
        push({Frame::Fragments, kOpen, false});
      } else if (vr_implicit || v == "SQ" || v == "UN") {
        push({Frame::Sequence, kOpen, vr_implicit || v == "UN"});  // an undefined-length UN is an implicit VR sequence
      } else {
        throw Error("element " + tag_str(t) + " (" + std::string(v) + ") has an undefined length");
      }
      continue;
    }
    fits(len, t);
    check_against_dictionary(t, vr_implicit ? nullptr : vr, len);
    if (v == "SQ") {
      push({Frame::Sequence, f.pos() + len, false});
    } else if (stack.empty() && kWanted.count(t)) {
      if (len > kMaxValueBytes) throw Error("element " + tag_str(t) + " is " + bytes_str(len) + " long (expected a short value)");
      std::string value(len, '\0');
      f.read(value.data(), len);
      h.values[t] = std::move(value);
    } else {
      if (t == kPixelData && stack.empty()) h.has_pixel_data = true, h.pixel_bytes = len, h.fragments = {{f.pos(), len}};
      f.skip(len);
    }
  }
  if (!stack.empty()) throw Error("truncated file: it ends inside a sequence or the pixel data");
  // Binary values of a big-endian data set are kept in host (little-endian) order, as GDCM keeps them.
  if (big_endian)
    for (const std::uint32_t t : {kSamplesPerPixel, kRows, kColumns, kBitsAllocated, kBitsStored, kHighBit, kPixelRepresentation})
      if (auto it = h.values.find(t); it != h.values.end() && it->second.size() == 2) std::swap(it->second[0], it->second[1]);
}

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

class Attributes {
public:
  explicit Attributes(const Header& h) : h_(h) {}
  bool has(std::uint32_t t) const { return h_.values.count(t) > 0; }
  std::string text(std::uint32_t t) const {
    auto it = h_.values.find(t);
    if (it == h_.values.end()) return "";
    std::string s(it->second.c_str());  // up to a NUL pad
    return std::string(io_detail::trim(s));
  }
  std::optional<int> us(std::uint32_t t, const char* name) const {
    auto it = h_.values.find(t);
    if (it == h_.values.end()) return std::nullopt;
    if (it->second.size() != 2) throw Error(std::string(name) + " " + tag_str(t) + " is " + bytes_str(it->second.size()) + " long (expected a 2-byte US value)");
    const auto* b = reinterpret_cast<const unsigned char*>(it->second.data());
    return b[0] | b[1] << 8;
  }
  int required_us(std::uint32_t t, const char* name) const {
    const auto v = us(t, name);
    if (!v) throw Error("no " + std::string(name) + " " + tag_str(t));
    return *v;
  }
  template <std::size_t N>
  std::optional<std::array<double, N>> numbers(std::uint32_t t, const char* name) const {
    if (!has(t) || text(t).empty()) return std::nullopt;
    const std::string s = text(t);
    const auto fields = io_detail::split_fields(s, "\\");
    std::array<double, N> out{};
    bool ok = fields.size() == N;
    for (std::size_t i = 0; ok && i < N; ++i) ok = io_detail::parse_number(fields[i], out[i]) && std::isfinite(out[i]);
    if (!ok) throw Error(std::string(name) + " " + tag_str(t) + " is '" + printable(s, 80) + "' (expected " + std::to_string(N) + " decimal number" + (N > 1 ? "s separated by \\)" : ")"));
    return out;
  }

private:
  const Header& h_;
};

// Bytes [offset, offset + length) of the file.
std::vector<unsigned char> read_bytes(const std::string& path, std::pair<std::uint64_t, std::uint32_t> range) {
  std::vector<unsigned char> out(range.second);
  std::ifstream in(path, std::ios::binary);
  if (!in.seekg(static_cast<std::streamoff>(range.first)) || !in.read(reinterpret_cast<char*>(out.data()), static_cast<std::streamsize>(out.size())))
    throw Error("cannot read the pixel data");
  return out;
}

// The frame a JPEG 2000 codestream must hold, as the slice's attributes say.
io_detail::Jpeg2000Frame jpeg2000_frame(const Slice& s) {
  io_detail::Jpeg2000Frame frame;
  frame.rows = s.rows;
  frame.cols = s.cols;
  frame.bits_allocated = s.bits_allocated;
  frame.is_signed = s.is_signed;
  return frame;
}

// A frame's fragments, concatenated (a frame may span several).
std::vector<unsigned char> read_frame(const Slice& s) {
  std::vector<unsigned char> data;
  for (const auto& fragment : s.fragments) {
    const std::vector<unsigned char> part = read_bytes(s.path, fragment);
    data.insert(data.end(), part.begin(), part.end());
  }
  return data;
}

// The image a JPEG or JPEG-LS codestream declares must be the one Rows and Columns declare: GDCM
// asserts (aborts) when the decoded frame is larger, and asserts on any warning of the IJG library
// while reading a JPEG header (bytes between marker segments, for one). So the codestream's header is
// read here first: marker segment after marker segment up to the scan.
void check_codestream(const Slice& s, const std::vector<unsigned char>& d) {
  auto u16 = [&](std::size_t i) { return static_cast<unsigned>(d[i] << 8 | d[i + 1]); };
  const std::string what = "JPEG";
  auto check_size = [&](std::uint64_t width, std::uint64_t height, unsigned components) {
    if (width != static_cast<unsigned>(s.cols) || height != static_cast<unsigned>(s.rows) || components != 1)
      throw Error(what + " codestream of " + std::to_string(width) + "x" + std::to_string(height) + " pixels with " +
                  std::to_string(components) + " components (expected " + std::to_string(s.cols) + "x" + std::to_string(s.rows) +
                  " with 1, as Columns and Rows say)");
  };
  // GDCM picks its 8-, 12- or 16-bit IJG decoder by BitsStored and, when the codestream's precision
  // differs, starts another by that precision: above 16 bits it dereferences a null decoder (SEGV).
  auto check_precision = [&](unsigned bits) {
    if (bits < 2 || bits > 16 || bits > static_cast<unsigned>(s.bits_allocated))
      throw Error(what + " samples of " + std::to_string(bits) + " bits (expected 2 to 16, and at most BitsAllocated " +
                  std::to_string(s.bits_allocated) + ")");
  };
  if (d.size() < 4 || u16(0) != 0xFFD8u) throw Error(what + " pixel data does not start with an SOI marker");
  bool size_seen = false;
  for (std::size_t i = 2;;) {
    while (i + 1 < d.size() && d[i] == 0xFF && d[i + 1] == 0xFF) ++i;  // fill bytes
    if (i + 4 > d.size()) throw Error(what + " header runs past the first fragment of the pixel data");
    const unsigned marker = u16(i), len = u16(i + 2);
    if ((marker & 0xFF00) != 0xFF00 || len < 2 || i + 2 + len > d.size())
      throw Error(what + " marker segment at byte " + std::to_string(i) + " does not fit the pixel data");
    if (((marker >= 0xFFC0 && marker <= 0xFFCF && marker != 0xFFC4 && marker != 0xFFC8 && marker != 0xFFCC) || marker == 0xFFF7)) {
      if (len < 8) throw Error("JPEG frame header too short");
      check_size(u16(i + 7), u16(i + 5), d[i + 9]);  // SOFn or JPEG-LS SOF55: precision, lines, samples per line, components
      check_precision(d[i + 4]);
      size_seen = true;
    } else if (marker == 0xFFDAu) {
      if (!size_seen) throw Error(what + " data starts before the frame header");
      return;  // the scan (the header IJG reads ends here)
    }
    i += 2 + len;
  }
}

// A JPEG or JPEG-LS frame ends with an EOI marker (FF D9), then at most the fragment's zero padding.
// Without it the codestream is cut short: IJG asks GDCM's stream for more bytes, GDCM suspends the
// decoder and fails without releasing it (about 750 KB a file).
void check_codestream_end(const std::string& path, std::pair<std::uint64_t, std::uint32_t> last_fragment) {
  const std::uint32_t tail = std::min<std::uint32_t>(last_fragment.second, 16);
  const std::vector<unsigned char> d = read_bytes(path, {last_fragment.first + last_fragment.second - tail, tail});
  std::size_t end = d.size();
  while (end > 0 && d[end - 1] == 0x00) --end;
  if (end < 2 || d[end - 2] != 0xFF || d[end - 1] != 0xD9)
    throw Error("JPEG pixel data does not end with an EOI marker (FF D9): the codestream is truncated");
}

// Reads a file's attributes; nullopt when the file is not a DICOM image and `skip_non_images` (a folder).
std::optional<Slice> read_slice(const std::string& path, const std::string& name, bool skip_non_images) {
  return with_context(name, [&]() -> std::optional<Slice> {
    Header h;
    try {
      walk_file(path, h);
    } catch (const Error&) {
      if (skip_non_images && !h.marker) return std::nullopt;
      throw;
    }
    const Attributes a(h);
    if (skip_non_images && !a.has(kRows) && !h.has_pixel_data) return std::nullopt;  // DICOMDIR, reports, ...
    if (!h.syntax)
      throw Error("transfer syntax " + printable(h.syntax_uid, 80) + " is not supported (expected uncompressed, RLE, JPEG, JPEG-LS or JPEG 2000)");
    Slice s;
    s.path = path;
    s.name = name;
    s.syntax = h.syntax;
    s.fragments = h.fragments;
    s.series_uid = a.text(kSeriesUid);
    s.description = a.text(kSeriesDescription);
    s.modality = a.text(kModality);
    if (double number = 0; io_detail::parse_number(a.text(kSeriesNumber), number) && std::abs(number) < 1e9) s.series_number = std::lround(number);
    s.rows = a.required_us(kRows, "Rows");
    s.cols = a.required_us(kColumns, "Columns");
    if (s.rows == 0 || s.cols == 0)
      throw Error("image of " + std::to_string(s.rows) + " rows and " + std::to_string(s.cols) + " columns (expected at least 1 of each)");
    if (const int spp = a.us(kSamplesPerPixel, "SamplesPerPixel").value_or(1); spp != 1)
      throw Error("SamplesPerPixel is " + std::to_string(spp) + " (expected 1: colour images are not supported)");
    s.photometric = a.text(kPhotometric);
    if (!s.photometric.empty() && s.photometric != "MONOCHROME1" && s.photometric != "MONOCHROME2")
      throw Error("PhotometricInterpretation " + printable(s.photometric, 40) + " is not supported (expected MONOCHROME1 or MONOCHROME2)");
    if (const auto frames = a.numbers<1>(kNumberOfFrames, "NumberOfFrames"); frames && (*frames)[0] != 1)
      throw Error("NumberOfFrames is " + num((*frames)[0]) + " (expected one frame per file: multi-frame images are not supported)");
    s.bits_allocated = a.required_us(kBitsAllocated, "BitsAllocated");
    s.bits_stored = a.us(kBitsStored, "BitsStored").value_or(s.bits_allocated);
    const int high_bit = a.us(kHighBit, "HighBit").value_or(s.bits_stored - 1);
    const int representation = a.us(kPixelRepresentation, "PixelRepresentation").value_or(0);
    if (s.bits_allocated != 8 && s.bits_allocated != 16 && s.bits_allocated != 32)
      throw Error("BitsAllocated is " + std::to_string(s.bits_allocated) + " (expected 8, 16 or 32)");
    if (s.bits_stored < 1 || s.bits_stored > s.bits_allocated || high_bit != s.bits_stored - 1)
      throw Error("BitsStored " + std::to_string(s.bits_stored) + " and HighBit " + std::to_string(high_bit) + " with BitsAllocated " +
                  std::to_string(s.bits_allocated) + " (expected 1 <= BitsStored <= BitsAllocated and HighBit = BitsStored - 1)");
    if (representation > 1) throw Error("PixelRepresentation is " + std::to_string(representation) + " (expected 0 or 1)");
    s.is_signed = representation == 1;
    s.position = a.numbers<3>(kPosition, "ImagePositionPatient");
    s.orientation = a.numbers<6>(kOrientation, "ImageOrientationPatient");
    s.pixel_spacing = a.numbers<2>(kPixelSpacing, "PixelSpacing");
    if (s.pixel_spacing && !((*s.pixel_spacing)[0] > 0 && (*s.pixel_spacing)[1] > 0))
      throw Error("PixelSpacing is '" + printable(a.text(kPixelSpacing), 80) + "' (expected two positive numbers)");
    if (const auto t = a.numbers<1>(kSliceThickness, "SliceThickness"); t && (*t)[0] > 0) s.thickness = (*t)[0];
    s.slope = a.numbers<1>(kRescaleSlope, "RescaleSlope").value_or(std::array<double, 1>{1})[0];
    s.intercept = a.numbers<1>(kRescaleIntercept, "RescaleIntercept").value_or(std::array<double, 1>{0})[0];
    if (s.slope == 0 || std::abs(s.slope) > 1e6 || std::abs(s.intercept) > 1e9)
      throw Error("RescaleSlope " + num(s.slope) + " and RescaleIntercept " + num(s.intercept) +
                  " (expected a slope of magnitude 1e-6..1e6, not 0, and an intercept within +-1e9)");
    if (!h.has_pixel_data) throw Error("no pixel data " + tag_str(kPixelData) + " (expected an image slice)");
    const std::uint64_t needed = static_cast<std::uint64_t>(s.rows) * s.cols * (s.bits_allocated / 8);
    if (!h.encapsulated && h.pixel_bytes < needed)
      throw Error("pixel data of " + bytes_str(h.pixel_bytes) + " for " + std::to_string(s.cols) + "x" + std::to_string(s.rows) + " pixels of " +
                  std::to_string(s.bits_allocated) + " bits (expected " + bytes_str(needed) + ")");
    if (h.encapsulated != (s.syntax->codec != Codec::None))
      throw Error(std::string("the pixel data is ") + (h.encapsulated ? "" : "not ") + "compressed (encapsulated) but the transfer syntax is " + s.syntax->name);
    if (h.encapsulated && h.fragments.empty()) throw Error("compressed pixel data without a fragment (expected the image after the offset table)");
    if (s.syntax->codec == Codec::Jpeg) {
      check_codestream(s, read_bytes(path, s.fragments[0]));
      check_codestream_end(path, s.fragments.back());
    }
    if (s.syntax->codec == Codec::Jpeg2000) io_detail::check_jpeg2000_header(read_bytes(path, s.fragments[0]), jpeg2000_frame(s));
    if (h.encapsulated && needed / kMaxCompressionRatio > h.pixel_bytes)
      throw Error("compressed pixel data of " + bytes_str(h.pixel_bytes) + " cannot hold " + std::to_string(s.cols) + "x" + std::to_string(s.rows) +
                  " pixels (" + bytes_str(needed) + ")");
    return s;
  });
}

struct Series {
  std::string uid, description, modality;
  std::optional<long> number;
  std::vector<Slice> slices;
};

std::string series_line(std::size_t index, const Series& s) {
  return std::to_string(index) + ": " + (s.uid.empty() ? "(no SeriesInstanceUID)" : s.uid) +
         (s.number ? " number " + std::to_string(*s.number) : "") + " \"" + printable(s.description, 80) + "\" " +
         (s.modality.empty() ? "?" : printable(s.modality, 16)) + ", " + std::to_string(s.slices.size()) + " slice" +
         (s.slices.size() == 1 ? "" : "s") + " of " + std::to_string(s.slices[0].rows) + "x" + std::to_string(s.slices[0].cols) + " (rows x columns)";
}

// Series in a stable order: by SeriesNumber, then UID (the order of the files does not matter).
std::vector<Series> group_series(std::vector<Slice> slices) {
  std::map<std::string, Series> by_uid;
  for (Slice& s : slices) {
    Series& series = by_uid[s.series_uid];
    if (series.slices.empty()) series.uid = s.series_uid, series.description = s.description, series.modality = s.modality, series.number = s.series_number;
    series.slices.push_back(std::move(s));
  }
  std::vector<Series> out;
  for (auto& [uid, series] : by_uid) out.push_back(std::move(series));
  std::stable_sort(out.begin(), out.end(), [](const Series& a, const Series& b) {
    return a.number.value_or(std::numeric_limits<long>::max()) < b.number.value_or(std::numeric_limits<long>::max());
  });
  return out;
}

std::size_t choose_series(const std::vector<Series>& all, const std::string& wanted, VolumeFileInfo& info) {
  if (wanted.empty()) {
    std::size_t best = 0;
    for (std::size_t i = 1; i < all.size(); ++i)
      if (all[i].slices.size() > all[best].slices.size()) best = i;
    if (all.size() > 1)
      info.notes.push_back("the input holds " + std::to_string(all.size()) + " series; loaded series " + std::to_string(best) +
                           ", the one with the most slices (choose another with 'series': its index or SeriesInstanceUID)");
    return best;
  }
  for (std::size_t i = 0; i < all.size(); ++i)
    if (all[i].uid == wanted) return i;
  if (wanted.find_first_not_of("0123456789") == std::string::npos && wanted.size() < 9 && std::stoul(wanted) < all.size())
    return std::stoul(wanted);
  std::string list;
  for (const std::string& line : info.series) list += "; " + line;
  throw Error("no series '" + printable(wanted, 80) + "' (expected a SeriesInstanceUID or an index from 0 to " + std::to_string(all.size() - 1) +
              "): the input holds" + list.substr(1));
}

void check_consistent(const std::vector<Slice>& slices) {
  const Slice& ref = slices[0];
  auto expect = [&](const Slice& s, bool same, const std::string& what, const std::string& found, const std::string& wanted) {
    if (!same) throw Error(s.name + ": " + what + " is " + found + ", expected " + wanted + " as in " + ref.name + " of the same series");
  };
  auto list = [](const auto& v) {
    std::string out;
    for (const double x : v) out += (out.empty() ? "" : "\\") + dec(x);
    return out;
  };
  auto close = [](const auto& a, const auto& b, double tol) {
    if (a.has_value() != b.has_value()) return false;
    for (std::size_t i = 0; a && i < a->size(); ++i)
      if (std::abs((*a)[i] - (*b)[i]) > tol) return false;
    return true;
  };
  auto opt_list = [&](const auto& v) { return v ? list(*v) : std::string("missing"); };
  for (const Slice& s : slices) {
    expect(s, s.rows == ref.rows, "Rows", std::to_string(s.rows), std::to_string(ref.rows));
    expect(s, s.cols == ref.cols, "Columns", std::to_string(s.cols), std::to_string(ref.cols));
    expect(s, s.bits_allocated == ref.bits_allocated, "BitsAllocated", std::to_string(s.bits_allocated), std::to_string(ref.bits_allocated));
    expect(s, s.bits_stored == ref.bits_stored, "BitsStored", std::to_string(s.bits_stored), std::to_string(ref.bits_stored));
    expect(s, s.is_signed == ref.is_signed, "PixelRepresentation", s.is_signed ? "1" : "0", ref.is_signed ? "1" : "0");
    expect(s, close(s.pixel_spacing, ref.pixel_spacing, 1e-4), "PixelSpacing", opt_list(s.pixel_spacing), opt_list(ref.pixel_spacing));
    expect(s, close(s.orientation, ref.orientation, 1e-4), "ImageOrientationPatient", opt_list(s.orientation), opt_list(ref.orientation));
    if (!s.position && slices.size() > 1) throw Error(s.name + ": no ImagePositionPatient " + tag_str(kPosition) + " (expected to order the slices by it)");
  }
}

using Vec3d = std::array<double, 3>;

double dot(const Vec3d& a, const Vec3d& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; }
Vec3d cross(const Vec3d& a, const Vec3d& b) {
  return {a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
}
std::string vec_str(const Vec3d& v) { return "(" + num(v[0]) + ", " + num(v[1]) + ", " + num(v[2]) + ")"; }

// The patient axis (0, 1, 2) and sign of a direction cosine along one, or -1 when it is oblique.
std::pair<int, int> axis_of(const Vec3d& v) {
  for (int a = 0; a < 3; ++a)
    if (std::abs(std::abs(v[a]) - 1) < 1e-3) return {a, v[a] > 0 ? 1 : -1};
  return {-1, 0};
}

std::string axis_str(const std::pair<int, int>& axis) { return std::string(axis.second > 0 ? "+" : "-") + "xyz"[axis.first]; }

// How the sorted slices become the volume: voxel (column i, row j, slice k) goes to index
// col[i] + row[j] + slice[k]; and the volume's grid.
struct Layout {
  std::vector<const Slice*> slices;  // sorted by position along the normal
  std::array<int, 3> dims{};
  Vec3 spacing, origin;
  std::vector<std::int64_t> col, row, slice;
};

Layout arrange(const std::vector<Slice>& input, VolumeFileInfo& info) {
  Layout L;
  const Slice& first = input[0];
  const std::size_t n = input.size();
  std::array<double, 6> iop{1, 0, 0, 0, 1, 0};
  if (first.orientation) iop = *first.orientation;
  else info.notes.push_back("no ImageOrientationPatient: the slice is taken as axial (rows along +x, columns along +y)");
  Vec3d r{iop[0], iop[1], iop[2]}, c{iop[3], iop[4], iop[5]};
  const double lr = std::sqrt(dot(r, r)), lc = std::sqrt(dot(c, c));
  if (std::abs(lr - 1) > 0.01 || std::abs(lc - 1) > 0.01 || std::abs(dot(r, c)) > 0.01)
    throw Error(first.name + ": ImageOrientationPatient " + vec_str(r) + " " + vec_str(c) + " (expected two orthogonal unit vectors)");
  for (double& x : r) x /= lr;
  for (double& x : c) x /= lc;
  const Vec3d normal = cross(r, c);

  // Sort along the normal; check the steps.
  std::vector<std::pair<double, const Slice*>> at;
  for (const Slice& s : input) at.push_back({s.position ? dot(*s.position, normal) : 0.0, &s});
  std::stable_sort(at.begin(), at.end(), [](const auto& a, const auto& b) { return a.first < b.first; });
  double step = 0;
  if (n > 1) {
    std::vector<double> diffs;
    for (std::size_t k = 1; k < n; ++k) diffs.push_back(at[k].first - at[k - 1].first);
    std::vector<double> sorted = diffs;
    std::nth_element(sorted.begin(), sorted.begin() + static_cast<std::ptrdiff_t>((n - 2) / 2), sorted.end());
    step = sorted[(n - 2) / 2];
    const double tol = std::max(0.01 * step, 0.01);
    for (std::size_t k = 1; k < n; ++k) {
      const Slice& a = *at[k - 1].second;
      const Slice& b = *at[k].second;
      const std::string pair = a.name + " (at " + num(at[k - 1].first) + " mm along the slice normal) and " + b.name + " (at " +
                               num(at[k].first) + " mm)";
      if (diffs[k - 1] < tol) throw Error("two slices at the same position: " + pair);
      const double missing = diffs[k - 1] / step - 1;  // slices missing between the two
      const std::string apart = num(diffs[k - 1]) + " mm apart, expected the step " + num(step) + " mm";
      if (std::abs(missing - std::round(missing)) * step < tol && missing > 0.5)
        throw Error("missing slice" + std::string(missing > 1.5 ? "s" : "") + " between " + pair + ": they are " + apart);
      if (std::abs(diffs[k - 1] - step) > tol) throw Error("slices not evenly spaced: " + pair + " are " + apart);
    }
    // Positions that also move within the slice plane (a tilted gantry) make a sheared grid.
    double shear = 0;
    for (const auto& [d, s] : at)
      for (int a = 0; a < 3; ++a) shear = std::max(shear, std::abs((*s->position)[a] - (*at[0].second->position)[a] - (d - at[0].first) * normal[a]));
    if (shear > tol)
      info.notes.push_back("slice positions move up to " + num(shear) + " mm within the slice plane (gantry tilt?): the shear is not applied");
    if (first.thickness && std::abs(*first.thickness - step) > tol)
      info.notes.push_back("slice spacing " + num(step) + " mm from ImagePositionPatient differs from SliceThickness " + num(*first.thickness) +
                           " mm: the positions are used");
  } else {
    step = first.thickness.value_or(1);
    info.notes.push_back("a single slice: its spacing along z is " +
                         (first.thickness ? "the SliceThickness, " + num(step) + " mm" : std::string("1 (no SliceThickness)")));
  }
  for (const auto& [d, s] : at) L.slices.push_back(s);

  bool same = true, reversed = true;
  for (std::size_t k = 0; k < n; ++k) same = same && L.slices[k] == &input[k], reversed = reversed && L.slices[k] == &input[n - 1 - k];
  if (n > 1)
    info.notes.push_back(std::string("slices sorted by ImagePositionPatient along the slice normal: ") +
                         (same ? "the file order" : reversed ? "file order reversed" : "not the file order"));

  std::array<double, 2> ps{1, 1};
  if (first.pixel_spacing) ps = *first.pixel_spacing;
  else info.notes.push_back("no PixelSpacing: the spacing within a slice is 1");
  const std::array<int, 3> grid{first.cols, first.rows, static_cast<int>(n)};
  const std::array<double, 3> grid_spacing{ps[1], ps[0], step};  // PixelSpacing is (between rows, between columns)
  const std::array<Vec3d, 3> dirs{r, c, normal};
  const std::array<std::pair<int, int>, 3> axes{axis_of(r), axis_of(c), axis_of(normal)};
  const bool aligned = axes[0].first >= 0 && axes[1].first >= 0 && axes[2].first >= 0;
  Vec3d origin = L.slices[0]->position.value_or(Vec3d{0, 0, 0});
  if (!L.slices[0]->position) info.notes.push_back("no ImagePositionPatient: the origin is 0");
  std::array<int, 3> to{0, 1, 2};     // volume axis of each grid axis
  std::array<bool, 3> flip{};
  if (aligned) {
    static const char* const plane[] = {"sagittal", "coronal", "axial"};
    info.orientation = std::string(plane[axes[2].first]) + " (rows along " + axis_str(axes[0]) + ", columns along " + axis_str(axes[1]) +
                       "), slices sorted by position along " + axis_str(axes[2]) + "; volume axes = patient LPS";
    for (int m = 0; m < 3; ++m) {
      to[m] = axes[m].first;
      flip[m] = axes[m].second < 0;
      if (flip[m])
        for (int a = 0; a < 3; ++a) origin[a] += (grid[m] - 1) * grid_spacing[m] * dirs[m][a];
    }
  } else {
    info.orientation = "oblique (rows along " + vec_str(r) + ", columns along " + vec_str(c) + "), slices sorted along the normal " +
                       vec_str(normal) + "; volume axes = columns, rows, slices";
    info.notes.push_back("oblique slices: the rotation is not applied; the volume is rendered on the slice grid (x along the rows, y down the "
                         "columns, z along the normal), with the first slice's ImagePositionPatient as origin");
  }
  for (int m = 0; m < 3; ++m) {
    L.dims[to[m]] = grid[m];
    L.spacing[to[m]] = static_cast<float>(grid_spacing[m]);
  }
  const std::array<std::int64_t, 3> stride{1, L.dims[0], static_cast<std::int64_t>(L.dims[0]) * L.dims[1]};
  L.origin = {static_cast<float>(origin[0]), static_cast<float>(origin[1]), static_cast<float>(origin[2])};
  std::array<std::vector<std::int64_t>*, 3> offsets{&L.col, &L.row, &L.slice};
  for (int m = 0; m < 3; ++m)
    for (int i = 0; i < grid[m]; ++i) offsets[m]->push_back((flip[m] ? grid[m] - 1 - i : i) * stride[to[m]]);
  return L;
}

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
bool fill(Volume& volume, const Layout& L) {
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

void quiet_gdcm() {
  static const bool done = [] {
    gdcm::Trace::SetDebug(false);
    gdcm::Trace::SetWarning(false);
    gdcm::Trace::SetError(false);
    return true;
  }();
  (void)done;
}

}  // namespace

Volume load_dicom_volume(const std::vector<std::string>& paths, const std::string& series, VolumeFileInfo* info_out) {
  quiet_gdcm();
  VolumeFileInfo local;
  VolumeFileInfo& info = info_out ? *info_out : local;
  info.format = "dicom";

  // The slices: every DICOM image in a folder and its subfolders (as exports from scanners and PACS
  // nest them: DICOM/ST000/SE001/IM0001, often without an extension; other files skipped), or the
  // files given.
  std::vector<Slice> slices;
  std::error_code ec;
  if (paths.size() == 1 && std::filesystem::is_directory(paths[0], ec)) {
    constexpr int kMaxDepth = 8;
    constexpr std::size_t kMaxFiles = 200000;
    std::vector<std::filesystem::path> files;
    try {
      namespace fs = std::filesystem;
      for (auto it = fs::recursive_directory_iterator(paths[0], fs::directory_options::skip_permission_denied);
           it != fs::recursive_directory_iterator(); ++it) {
        if (it.depth() >= kMaxDepth) it.disable_recursion_pending();
        if (std::error_code entry_ec; it->is_regular_file(entry_ec)) files.push_back(it->path());
        if (files.size() > kMaxFiles)
          throw Error("holds more than " + std::to_string(kMaxFiles) + " files (expected a folder of DICOM slices)");
      }
    } catch (const std::filesystem::filesystem_error& e) {
      throw Error("cannot list the folder (" + e.code().message() + ")");
    }
    std::sort(files.begin(), files.end());
    for (const auto& file : files)
      if (auto s = read_slice(file.string(), file.lexically_relative(paths[0]).generic_string(), true)) slices.push_back(std::move(*s));
    if (slices.empty())
      throw Error("none of the " + std::to_string(files.size()) + " files in the folder and its subfolders is a DICOM image "
                  "(expected a folder of DICOM slices)");
    if (slices.size() < files.size())
      info.notes.push_back(files.size() - slices.size() == 1 ? std::string("1 file in the folder is not a DICOM image: skipped")
                                                            : std::to_string(files.size() - slices.size()) + " files in the folder are not DICOM images: skipped");
  } else {
    for (const std::string& p : paths) slices.push_back(*read_slice(p, p, false));
  }

  std::vector<Series> all = group_series(std::move(slices));
  for (std::size_t i = 0; i < all.size(); ++i) info.series.push_back(series_line(i, all[i]));
  const std::size_t chosen = choose_series(all, series, info);
  info.series_index = static_cast<int>(chosen);
  std::vector<Slice>& chosen_slices = all[chosen].slices;
  check_consistent(chosen_slices);
  const Layout L = arrange(chosen_slices, info);
  (void)checked_voxel_count({L.dims[0], L.dims[1], L.dims[2]});

  // Output type: the stored one when nothing is rescaled, int16 when the rescaled values are integers
  // that fit, float32 otherwise.
  bool rescaled = false, integral = true, same_rescale = true;
  for (const Slice* s : L.slices) {
    rescaled = rescaled || s->slope != 1 || s->intercept != 0;
    integral = integral && s->slope == std::round(s->slope) && s->intercept == std::round(s->intercept) && std::abs(s->slope) <= 65536;
    same_rescale = same_rescale && s->slope == L.slices[0]->slope && s->intercept == L.slices[0]->intercept;
  }
  const Slice& first = *L.slices[0];
  ScalarType type = ScalarType::Float32;
  if (integral && !rescaled && !first.is_signed && first.bits_allocated == 8) type = ScalarType::UInt8;
  else if (integral && !rescaled && !first.is_signed && first.bits_allocated == 16) type = ScalarType::UInt16;
  else if (integral) type = ScalarType::Int16;
  Volume volume(type, L.dims, L.spacing, L.origin, VoxelFill::Uninitialized);
  const bool filled = volume.with_voxel_type([&](auto t) { return fill<decltype(t)>(volume, L); });
  if (!filled) {
    info.notes.push_back("rescaled values do not fit int16: the volume is float32");
    volume = Volume(ScalarType::Float32, L.dims, L.spacing, L.origin, VoxelFill::Uninitialized);
    fill<float>(volume, L);
  }
  if (rescaled)
    info.notes.push_back(same_rescale ? "rescale slope " + num(first.slope) + " intercept " + num(first.intercept) + " applied" +
                                            (first.modality == "CT" ? ": values are Hounsfield units" : "")
                                      : std::string("rescale slope and intercept applied per slice (they differ between slices)"));
  if (first.photometric == "MONOCHROME1") info.notes.push_back("MONOCHROME1: low values are displayed bright by DICOM viewers; the values are kept");
  std::set<std::string> lossy;
  for (const Slice* s : L.slices)
    if (s->syntax->lossy) lossy.insert(s->syntax->name);
  for (const std::string& name : lossy) info.notes.push_back("pixel data compressed with lossy " + name);
  volume.recompute_range();
  return volume;
}

}  // namespace penumbra
