// The walk of one DICOM file: every element, sequence and pixel-data fragment must nest properly and
// fit in the file; the attributes the volume needs are read on the way, and a compressed frame's
// codestream header is checked against Rows and Columns before any codec sees it.
#include "penumbra/data/io/dicom_slice.h"

#include <gdcmDicts.h>
#include <gdcmGlobal.h>

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/text_fields.h"

namespace penumbra::dicom {

using io_detail::bytes_str;
using io_detail::printable;

constexpr std::uint32_t kTransferSyntaxUid = tag(0x0002, 0x0010);
constexpr std::uint32_t kModality = tag(0x0008, 0x0060);
constexpr std::uint32_t kSeriesDescription = tag(0x0008, 0x103E);
constexpr std::uint32_t kSliceThickness = tag(0x0018, 0x0050);
constexpr std::uint32_t kSeriesUid = tag(0x0020, 0x000E);
constexpr std::uint32_t kSeriesNumber = tag(0x0020, 0x0011);
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

}  // namespace penumbra::dicom
