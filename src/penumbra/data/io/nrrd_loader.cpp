// NRRD volumes (.nrrd with attached data, .nhdr with a detached "data file") read with teem's help.
// teem trusts its header: it allocates whatever `sizes` asks for before reading a byte, and a detached
// "data file" in its printf-template form is handed to sprintf. So the header is first parsed here,
// with teem's own tables for the names of fields, types and encodings, and rejected unless it is a
// 3-D volume of a supported type whose voxel count is sane and which the data on disk could hold.
// Only then does nrrdLoad run, and its result is checked against the pre-parse again. For raw and gzip
// data (nearly every volume) teem parses the header only and leaves the data file open at the data,
// which is then read once, straight into the volume (a 900 MB CT never exists twice), gzip streams
// checked to their checksum (gzip_stream.h); teem reads the other encodings into a buffer of its own.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <teem/nrrd.h>

#include "penumbra/data/io/byte_order.h"
#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/gzip_stream.h"
#include "penumbra/data/io/parked_stream.h"
#include "penumbra/data/io/text_fields.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/io/volume_placement.h"

namespace penumbra {

namespace {

using io_detail::bytes_str;
using io_detail::GzipStream;
using io_detail::printable;
using io_detail::split_fields;
using io_detail::trim;

// teem keeps errors (biff) and settings in globals, so calls into it are serialised.
std::mutex teem_mutex;

// A header longer than this is not a volume header (teem would read lines of any length).
constexpr std::uint64_t kMaxHeaderBytes = 1u << 20;
// teem formats its error messages into a fixed 1025-byte stack buffer (biff, AIR_STRLEN_HUGE) and quotes
// the offending field value in many of them: a field line of about 1000 characters that teem cannot
// parse overflows it ("buffer overflow detected"). Field lines are refused above this length, far above
// any real header's (three space directions at full double precision take under 200 characters).
constexpr std::size_t kMaxFieldLine = 512;

struct NrrdHeader {
  std::optional<unsigned> dimension;
  std::vector<std::int64_t> sizes;
  int type = nrrdTypeUnknown;
  std::string type_name;
  int encoding = nrrdEncodingTypeUnknown;
  std::string encoding_name;
  std::optional<std::string> data_file;
  std::vector<std::string> kinds;  // as written, one per axis
  std::int64_t byte_skip = 0;
  std::int64_t line_skip = 0;
  std::uint64_t header_end = 0;  // offset of the first data byte when the data is attached
  bool complete = false;         // saw the blank line that ends an attached header
};

// teem's airOneLinify, which cleans each comment, reads one byte before the comment when the comment
// is made only of bytes it deletes (control and non-ASCII bytes in the C locale) after the leading '#'
// and blanks it skips. Such a comment is refused here.
void check_comment(std::string_view line, std::size_t line_no) {
  const std::size_t start = line.find_first_not_of(" #");
  if (start == std::string_view::npos) return;  // nothing left: teem drops the comment
  for (const char ch : line.substr(start)) {
    const auto c = static_cast<unsigned char>(ch);
    if ((c >= 0x20 && c < 0x7f) || c == '\t' || c == '\v' || c == '\f' || c == '\r') return;
  }
  throw Error("line " + std::to_string(line_no) +
              ": a comment made only of control or non-ASCII bytes (teem cannot read such a comment safely)");
}

// The value of "labels", "units" and "space units" must be exactly `count` double-quoted strings: teem
// leaks memory on an unterminated string and on too many strings, so the quotes are checked here the way
// teem scans them (a backslash before a quote escapes it).
void check_quoted_strings(std::string_view value, std::size_t count, const std::string& where) {
  std::size_t i = 0;
  for (std::size_t k = 0; k < count; ++k) {
    while (i < value.size() && (value[i] == ' ' || value[i] == '\t')) ++i;
    if (i == value.size() || value[i] != '"')
      throw Error(where + " expected " + std::to_string(count) + " double-quoted strings, found '" + printable(value, 80) + "'");
    ++i;
    while (i < value.size() && value[i] != '"') i += (value[i] == '\\' && i + 1 < value.size() && value[i + 1] == '"') ? 2 : 1;
    if (i == value.size()) throw Error(where + " string " + std::to_string(k + 1) + " has no closing '\"'");
    ++i;
  }
  // teem leaks the strings it has read when more follow (found by fuzz_nrrd)
  while (i < value.size() && (value[i] == ' ' || value[i] == '\t')) ++i;
  if (i != value.size())
    throw Error(where + " expected " + std::to_string(count) + " double-quoted strings, found more: '" + printable(value, 80) + "'");
}

bool is_per_axis(int field) {
  switch (field) {
    case nrrdField_sizes: case nrrdField_spacings: case nrrdField_thicknesses: case nrrdField_axis_mins:
    case nrrdField_axis_maxs: case nrrdField_space_directions: case nrrdField_centers: case nrrdField_kinds:
    case nrrdField_labels: case nrrdField_units: return true;
    default: return false;
  }
}

// Header text quoted in an Error: control and non-ASCII bytes (garbage files have plenty) become '?'.
// Whole-token integer parse; anything teem might read differently (signs, hex, trailing junk) fails.
std::optional<std::int64_t> parse_int(std::string_view s, bool allow_negative) {
  if (s.empty() || s.size() > 18) return std::nullopt;
  std::size_t i = 0;
  bool negative = false;
  if (allow_negative && s[0] == '-') negative = true, i = 1;
  if (i == s.size()) return std::nullopt;
  std::int64_t v = 0;
  for (; i < s.size(); ++i) {
    if (s[i] < '0' || s[i] > '9') return std::nullopt;
    v = v * 10 + (s[i] - '0');
  }
  return negative ? -v : v;
}

NrrdHeader parse_header(const std::string& path, std::uint64_t file_bytes) {
  const std::uint64_t prefix_bytes = std::min(file_bytes, kMaxHeaderBytes);
  std::string text(static_cast<std::size_t>(prefix_bytes), '\0');
  std::ifstream in(path, std::ios::binary);
  if (!in || !in.read(text.data(), static_cast<std::streamsize>(prefix_bytes)))
    throw Error("cannot read the file");
  if (file_bytes == 0) throw Error("empty file (expected a NRRD header starting with NRRD000x)");

  NrrdHeader h;
  std::size_t pos = 0, line_no = 0;
  bool first = true;
  std::vector<int> seen;
  std::optional<std::int64_t> space_dim;
  while (pos < text.size()) {
    ++line_no;
    const std::size_t nl = text.find('\n', pos);
    if (nl == std::string::npos && prefix_bytes < file_bytes)
      throw Error("NRRD header line longer than " + bytes_str(kMaxHeaderBytes));
    const std::size_t end = nl == std::string::npos ? text.size() : nl;
    std::string_view line(text.data() + pos, end - pos);
    pos = nl == std::string::npos ? text.size() : nl + 1;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (first) {
      if (!((line.size() == 8 && line.substr(0, 7) == "NRRD000" && line[7] >= '1' && line[7] <= '9') || line == "NRRD00.01"))
        throw Error("not a NRRD file (it does not start with a NRRD000x magic line)");
      first = false;
      continue;
    }
    if (line.empty()) {
      h.complete = true;
      break;
    }
    const std::string where = "line " + std::to_string(line_no) + ":";
    // teem reads header lines as C strings ending at "\n", "\r\n" or a lone "\r"; a NUL byte or a lone
    // carriage return would make it see other lines than those checked here.
    if (line.find('\0') != std::string_view::npos) throw Error(where + " a NUL byte in the NRRD header");
    if (line.find('\r') != std::string_view::npos) throw Error(where + " a carriage return inside a NRRD header line");
    if (line[0] == '#') {
      check_comment(line, line_no);
      continue;
    }
    // Lines are classified as teem does: "name: value" with a known field name, else "key:=value".
    const std::size_t colon = line.find(": ");
    const std::string key(line.substr(0, std::min(colon, line.size())));
    const int field = colon == std::string_view::npos ? nrrdField_unknown : airEnumVal(nrrdField, key.c_str());
    if (field == nrrdField_unknown || field == nrrdField_comment || field == nrrdField_keyvalue) {
      if (line.find(":=") != std::string_view::npos) continue;  // key:=value, which teem stores unquoted
      throw Error(where + " '" + printable(key, 60) + (key.size() > 60 ? "…" : "") +
                  "' is neither a NRRD field ('name: value') nor a key/value pair ('key:=value')");
    }
    if (line.size() > kMaxFieldLine && field != nrrdField_content && field != nrrdField_sample_units)
      throw Error(where + " the '" + key + "' line is " + std::to_string(line.size()) + " characters long (at most " +
                  std::to_string(kMaxFieldLine) + " expected)");
    const std::string_view value = trim(line.substr(colon + 2));
    if (std::find(seen.begin(), seen.end(), field) != seen.end())
      throw Error("NRRD field '" + printable(key) + "' appears twice");
    if (is_per_axis(field) && !h.dimension)
      throw Error(where + " the per-axis field '" + key + "' comes before 'dimension'");
    seen.push_back(field);
    switch (field) {
      case nrrdField_labels:
      case nrrdField_units:
        check_quoted_strings(value, *h.dimension, where + " '" + key + "':");
        break;
      case nrrdField_space_units:
        if (!space_dim) throw Error(where + " 'space units' comes before 'space' or 'space dimension'");
        check_quoted_strings(value, static_cast<std::size_t>(*space_dim), where + " 'space units':");
        break;
      case nrrdField_space_dimension: {
        const auto d = parse_int(value, false);
        if (!d || *d < 1 || *d > NRRD_SPACE_DIM_MAX) throw Error(where + " 'space dimension' is not 1 to " + std::to_string(NRRD_SPACE_DIM_MAX));
        space_dim = *d;
        break;
      }
      case nrrdField_space: {
        const std::string name(value);
        const int space = airEnumVal(nrrdSpace, name.c_str());
        if (space != nrrdSpaceUnknown) space_dim = nrrdSpaceDimension(space);
        break;
      }
      case nrrdField_dimension: {
        const auto d = parse_int(value, false);
        if (!d || *d > 1000) throw Error("NRRD dimension '" + printable(value) + "' is not a small number");
        h.dimension = static_cast<unsigned>(*d);
        break;
      }
      case nrrdField_sizes:
        for (const auto token : split_fields(value)) {
          const auto v = parse_int(token, true);
          if (!v) throw Error("NRRD sizes '" + printable(value) + "' are not whole numbers (or absurdly large)");
          h.sizes.push_back(*v);
        }
        break;
      case nrrdField_type:
        h.type_name = value;
        h.type = airEnumVal(nrrdType, h.type_name.c_str());
        break;
      case nrrdField_encoding:
        h.encoding_name = value;
        h.encoding = airEnumVal(nrrdEncodingType, h.encoding_name.c_str());
        break;
      case nrrdField_data_file: h.data_file = std::string(value); break;
      case nrrdField_kinds:
        for (const auto token : split_fields(value)) h.kinds.emplace_back(token);
        break;
      case nrrdField_block_size:  // teem leaks when it refuses a block size for another type
        throw Error(where + " 'block size' belongs to type 'block', which penumbra does not read (a volume of "
                    "uint8, int16, uint16 or float expected)");
      case nrrdField_line_skip: {
        const auto v = parse_int(value, false);
        if (!v) throw Error("NRRD line skip '" + printable(value) + "' is not a line count");
        h.line_skip = *v;
        break;
      }
      case nrrdField_byte_skip: {
        const auto v = parse_int(value, true);
        if (!v || *v < -1) throw Error("NRRD byte skip '" + printable(value) + "' is not -1 or a byte count");
        h.byte_skip = *v;
        break;
      }
      default: break;
    }
  }
  if (first) throw Error("not a NRRD file (no magic line)");
  if (!h.complete && prefix_bytes < file_bytes)
    throw Error("NRRD header is longer than " + bytes_str(kMaxHeaderBytes) + " or lacks the blank line before the data");
  h.header_end = pos;
  return h;
}

struct Checked {
  std::array<std::int64_t, 3> dims{};
  std::uint64_t needed_bytes = 0;
  std::filesystem::path data_path;  // the file holding the data, and where in it the data starts
  std::uint64_t data_start = 0;
};

// Rejects every header teem should not be allowed to act on, and a data file outside `confine_to`.
Checked check_header(const NrrdHeader& h, const std::filesystem::path& header_path, std::uint64_t file_bytes, const std::string& confine_to) {
  if (!h.dimension) throw Error("NRRD header has no 'dimension' field");
  if (*h.dimension != 3)
    throw Error("NRRD dimension is " + std::to_string(*h.dimension) + " (expected 3: a scalar volume)");
  if (h.sizes.size() != 3)
    throw Error("NRRD 'sizes' has " + std::to_string(h.sizes.size()) + " values (expected 3)");
  Checked c;
  c.dims = {h.sizes[0], h.sizes[1], h.sizes[2]};
  const std::size_t count = with_context("NRRD sizes", [&] { return checked_voxel_count(c.dims); });
  for (const auto s : c.dims)
    if (s > std::numeric_limits<int>::max()) throw Error("NRRD size " + std::to_string(s) + " is too large");
  // teem leaks when its check after reading refuses a kind of fixed size (an RGB or HSV colour, a
  // vector, a tensor) on an axis of another size (found by fuzz_nrrd in CI, 2026-12-05).
  for (std::size_t axis = 0; axis < h.kinds.size() && axis < 3; ++axis) {
    const int kind = airEnumVal(nrrdKind, h.kinds[axis].c_str());
    const unsigned fixed = kind == nrrdKindUnknown ? 0u : nrrdKindSize(kind);
    if (fixed != 0 && static_cast<std::int64_t>(fixed) != c.dims[axis])
      throw Error("NRRD axis " + std::to_string(axis) + " is of kind '" + printable(h.kinds[axis]) + "', which has " +
                  std::to_string(fixed) + " samples, but its size is " + std::to_string(c.dims[axis]));
  }

  switch (h.type) {
    case nrrdTypeChar: case nrrdTypeUChar: case nrrdTypeShort: case nrrdTypeUShort:
    case nrrdTypeInt: case nrrdTypeUInt: case nrrdTypeFloat: case nrrdTypeDouble: break;
    case nrrdTypeUnknown:
      throw Error(h.type_name.empty() ? "NRRD header has no 'type' field"
                                      : "unknown NRRD type '" + printable(h.type_name) + "'");
    default:
      throw Error("NRRD type '" + h.type_name +
                  "' is not supported (expected (u)char, (u)short, (u)int, float or double)");
  }
  c.needed_bytes = static_cast<std::uint64_t>(count) * nrrdTypeSize[h.type];

  // How many bytes the data can come from: the detached file, or what follows the attached header.
  std::uint64_t available = 0;
  if (h.data_file) {
    const std::string& name = *h.data_file;
    // teem treats "LIST"/"SKIPLIST", "-" (stdin) and names with %d (a sprintf template) specially;
    // one plain file is all a volume needs, and the rest is unsafe to hand to teem unchecked.
    if (name.empty() || name == "-" || name.find('%') != std::string::npos || name.rfind("LIST", 0) == 0 ||
        name.rfind("SKIPLIST", 0) == 0)
      throw Error("NRRD 'data file: " + printable(name) + "' is not supported (expected one plain file name)");
    c.data_path = name;
    if (c.data_path.is_relative()) c.data_path = header_path.parent_path() / c.data_path;
    io_detail::check_inside(c.data_path, confine_to, "data file");  // before anything about the file is said
    available = with_context("data file " + c.data_path.string(), [&] { return io_detail::regular_file_size(c.data_path); });
  } else {
    if (!h.complete) throw Error("NRRD header has neither a blank line followed by data nor a 'data file' field");
    c.data_path = header_path;
    c.data_start = h.header_end;
    available = file_bytes - h.header_end;
  }

  const bool compressed = h.encoding == nrrdEncodingTypeGzip;
  if (!compressed && h.byte_skip > 0) available -= std::min<std::uint64_t>(available, static_cast<std::uint64_t>(h.byte_skip));
  bool could_hold = true;
  switch (h.encoding) {
    case nrrdEncodingTypeRaw: could_hold = available >= c.needed_bytes; break;
    case nrrdEncodingTypeGzip: could_hold = io_detail::deflate_could_hold(available, c.needed_bytes); break;
    case nrrdEncodingTypeAscii: could_hold = available >= count; break;  // at least a digit per value
    case nrrdEncodingTypeHex: could_hold = available / 2 >= c.needed_bytes; break;
    case nrrdEncodingTypeUnknown:
      throw Error(h.encoding_name.empty() ? "NRRD header has no 'encoding' field"
                                          : "unknown NRRD encoding '" + printable(h.encoding_name) + "'");
    default:
      // bzip2 can expand almost without bound and zrl is rare; neither is needed for volumes here.
      throw Error("NRRD encoding '" + printable(h.encoding_name) + "' is not supported (expected raw, gzip, ascii or hex)");
  }
  if (!could_hold)
    throw Error("NRRD sizes " + std::to_string(c.dims[0]) + "x" + std::to_string(c.dims[1]) + "x" +
                std::to_string(c.dims[2]) + " of type " + printable(h.type_name) + " need " + bytes_str(c.needed_bytes) +
                " but the " + printable(h.encoding_name) + " data has only " + bytes_str(available) +
                " (truncated data or lying sizes)");
  return c;
}

struct FileCloser {
  void operator()(std::FILE* f) const { std::fclose(f); }
};
using File = std::unique_ptr<std::FILE, FileCloser>;

// "sizes 8x8x16 of type uchar need 1024 bytes", for messages about data that runs short.
std::string need_text(const Checked& c, const NrrdHeader& h, std::uint64_t bytes) {
  return "sizes " + std::to_string(c.dims[0]) + "x" + std::to_string(c.dims[1]) + "x" + std::to_string(c.dims[2]) +
         " of type " + printable(h.type_name) + " need " + bytes_str(bytes);
}

// The gzip stream that teem will read by itself (data placed by a negative byte skip, which teem finds
// by decompressing everything), checked to its end before teem gets to it.
void verify_gzip(const Checked& c, const NrrdHeader& h) {
  const File in(std::fopen(c.data_path.c_str(), "rb"));
  if (!in || std::fseek(in.get(), static_cast<long>(c.data_start), SEEK_SET) != 0) throw Error("cannot read the NRRD data");
  for (std::int64_t line = 0; line < h.line_skip; ++line) {
    int ch = 0;
    while ((ch = std::getc(in.get())) != EOF && ch != '\n') {
    }
    if (ch == EOF) throw Error("NRRD line skip " + std::to_string(h.line_skip) + " runs past the end of the data");
  }
  GzipStream gz(in.get(), "NRRD gzip data", c.needed_bytes, need_text(c, h, c.needed_bytes));
  gz.read(nullptr, c.needed_bytes);
  gz.finish();
}

// teem's error (biff) text, one line per call level from nrrdLoad down. The outer levels only say
// "trouble"; the detail is in the rest, which is joined into one line.
std::string take_biff_message() {
  char* raw = biffGetDone(NRRD);
  const std::string msg = raw ? raw : "";
  std::free(raw);
  std::string out;
  std::size_t pos = 0;
  while (pos < msg.size()) {
    const std::size_t nl = std::min(msg.find('\n', pos), msg.size());
    std::string_view line(msg.data() + pos, nl - pos);
    pos = nl + 1;
    if (line.rfind("[nrrd] ", 0) == 0) line.remove_prefix(7);
    const std::size_t colon = line.find(": ");
    const std::string_view detail = trim(colon == std::string_view::npos ? std::string_view{} : line.substr(colon + 2));
    if (detail.empty() || detail == "trouble" || detail.rfind("trouble reading", 0) == 0) continue;
    if (!out.empty()) out += "; ";
    out += line;
  }
  return out.empty() ? "unknown teem error" : printable(out, 2000);
}

struct NrrdNuker {
  void operator()(Nrrd* n) const { nrrdNuke(n); }
};
struct NioNixer {
  void operator()(NrrdIoState* nio) const { nrrdIoStateNix(nio); }
};

// What teem read: the header as a Nrrd, with either its own copy of the data or, `header_only`, the
// data file left open at the first data byte (after teem's line skip, and its byte skip for raw data).
struct TeemRead {
  std::unique_ptr<Nrrd, NrrdNuker> nrrd;
  File data;
  int endian = airEndianUnknown;  // the byte order of the data on disk
};

TeemRead teem_load(const std::filesystem::path& path, bool header_only) {
  TeemRead r;
  std::lock_guard lock(teem_mutex);
  nrrdStateVerboseIO = 0;
  r.nrrd.reset(nrrdNew());
  const std::unique_ptr<NrrdIoState, NioNixer> nio(nrrdIoStateNew());
  if (!r.nrrd || !nio) throw Error("teem could not allocate a Nrrd");
  // skipData: parse the header and open the data file but allocate and read nothing;
  // keepNrrdDataFileOpen: hand that file over, positioned at the data.
  nio->skipData = nio->keepNrrdDataFileOpen = header_only ? AIR_TRUE : AIR_FALSE;
  if (nrrdLoad(r.nrrd.get(), path.c_str(), nio.get())) throw Error("teem could not read the NRRD: " + take_biff_message());
  r.data.reset(nio->dataFile);
  r.endian = nio->endian;
  if (header_only && !r.data) throw Error("teem did not open the NRRD data");
  return r;
}

// The types kept as they are (the voxels are read straight into the volume); the others are widened to
// int16 (signed char) or converted to float32.
bool stored_as_is(int nrrd_type) {
  return nrrd_type == nrrdTypeUChar || nrrd_type == nrrdTypeShort || nrrd_type == nrrdTypeUShort || nrrd_type == nrrdTypeFloat;
}

ScalarType nrrd_storage_type(int nrrd_type) {
  switch (nrrd_type) {
    case nrrdTypeUChar: return ScalarType::UInt8;
    case nrrdTypeChar:
    case nrrdTypeShort: return ScalarType::Int16;  // int8 fits int16 exactly
    case nrrdTypeUShort: return ScalarType::UInt16;
    default: return ScalarType::Float32;
  }
}

// Voxels [first, first + count) of a type penumbra does not store natively, widened or converted to
// float32 (int and uint above 2^24 lose precision, which a renderer does not see; double outside float
// range is an error).
template <class Src>
void convert_to(const std::byte* src, std::size_t first, std::size_t count, Volume& volume) {
  const auto* in = reinterpret_cast<const Src*>(src);
  if (volume.type() == ScalarType::Int16) {
    auto* out = volume.data_as<std::int16_t>() + first;
    for (std::size_t i = 0; i < count; ++i) out[i] = static_cast<std::int16_t>(in[i]);
    return;
  }
  auto* out = volume.data_as<float>() + first;
  for (std::size_t i = 0; i < count; ++i) {
    const double v = static_cast<double>(in[i]);
    if (std::abs(v) > std::numeric_limits<float>::max())
      throw Error("voxel " + std::to_string(first + i) + " value " + std::to_string(v) + " is outside the float32 range");
    out[i] = static_cast<float>(v);  // NaN passes through and is rejected by recompute_range
  }
}

void convert(int nrrd_type, const std::byte* src, std::size_t first, std::size_t count, Volume& volume) {
  switch (nrrd_type) {
    case nrrdTypeChar: convert_to<signed char>(src, first, count, volume); break;
    case nrrdTypeInt: convert_to<std::int32_t>(src, first, count, volume); break;
    case nrrdTypeUInt: convert_to<std::uint32_t>(src, first, count, volume); break;
    case nrrdTypeDouble: convert_to<double>(src, first, count, volume); break;
    default: throw Error("unsupported NRRD type");
  }
}

// Fills the volume from `next(dst, bytes)`, which yields the data's bytes in order: the types stored as
// they are go straight into the volume's storage (one copy of the voxels, byte order fixed in place),
// the others through a buffer of 1 M values.
template <class Next>
void read_voxels(Next&& next, int nrrd_type, bool swap, Volume& volume) {
  const std::size_t size = nrrdTypeSize[nrrd_type], n = volume.voxel_count();
  if (stored_as_is(nrrd_type)) {
    next(volume.data(), n * size);
    if (swap) io_detail::swap_bytes(volume.data(), n, size);
    return;
  }
  constexpr std::size_t kChunk = 1u << 20;
  std::vector<std::byte> buffer(std::min(n, kChunk) * size);
  for (std::size_t first = 0; first < n; first += kChunk) {
    const std::size_t count = std::min(kChunk, n - first);
    next(buffer.data(), count * size);
    if (swap) io_detail::swap_bytes(buffer.data(), count, size);
    convert(nrrd_type, buffer.data(), first, count, volume);
  }
}

// Raw or gzip data, read from the file teem left open at the data straight into the volume, which
// holds slices [first_slice, first_slice + its slices) of the file's grid: raw data seeks past the
// slices before them, gzip data decompresses and drops them (continuing from where the last window of
// the file ended, when that is not past them), and neither reads past the last (a window that stops short
// of the end leaves the gzip checksum unread, its stream parked). Returns the bytes read from the file.
// A gzip stream with the data file it reads, parked where the last window ended (parked_stream.h).
struct OpenGzip {
  File file;
  std::unique_ptr<GzipStream> gz;
};
io_detail::ParkedStream<OpenGzip> parked_gzip;

std::uint64_t read_data_file(TeemRead& teem, const std::filesystem::path& header_path, const NrrdHeader& h, const Checked& c,
                             int first_slice, Volume& volume) {
  const int type = teem.nrrd->type;
  const bool swap = nrrdTypeSize[type] > 1 && teem.endian != airEndianUnknown && teem.endian != airMyEndian();
  const std::uint64_t before = static_cast<std::uint64_t>(c.dims[0]) * static_cast<std::uint64_t>(c.dims[1]) *
                               static_cast<std::uint64_t>(first_slice) * nrrdTypeSize[type];
  const bool to_the_end = first_slice + volume.dims()[2] == c.dims[2];
  if (h.encoding == nrrdEncodingTypeGzip) {
    const auto skip = static_cast<std::uint64_t>(h.byte_skip);  // counted in the decompressed bytes
    const std::string key = header_path.string(), data = c.data_path.string();
    std::uint64_t at = 0;  // where the stream stands in the decompressed bytes
    std::optional<OpenGzip> open = first_slice > 0 ? parked_gzip.resume(key, data, skip + before, at) : std::nullopt;
    if (!open) {
      open.emplace();
      open->file = std::move(teem.data);
      open->gz = std::make_unique<GzipStream>(open->file.get(), "NRRD gzip data", c.needed_bytes + skip, need_text(c, h, c.needed_bytes + skip));
    }
    const long start = std::ftell(open->file.get());
    open->gz->read(nullptr, skip + before - at);
    read_voxels([&](std::byte* dst, std::size_t bytes) { open->gz->read(dst, bytes); }, type, swap, volume);
    const auto bytes = static_cast<std::uint64_t>(std::max(0L, std::ftell(open->file.get()) - start));
    if (to_the_end) open->gz->finish();
    else parked_gzip.park(key, data, std::move(*open), skip + before + volume.voxel_count() * nrrdTypeSize[type]);
    return bytes;
  }
  std::uint64_t done = before;
  if (before > 0 && fseeko(teem.data.get(), static_cast<off_t>(before), SEEK_CUR) != 0)
    throw Error("NRRD raw data: cannot seek to slice " + std::to_string(first_slice));
  const auto next = [&](std::byte* dst, std::size_t bytes) {
    const std::size_t got = std::fread(dst, 1, bytes, teem.data.get());
    done += got;
    if (got != bytes)
      throw Error("NRRD raw data ends after " + bytes_str(done) + " of the " + bytes_str(c.needed_bytes) +
                  " needed (truncated data or lying sizes)");
  };
  read_voxels(next, type, swap, volume);
  return done - before;
}

// The index-to-world affine in LPS: `space directions` and `space origin` turned from the NRRD's
// `space` (right-anterior-superior: x and y negated; left-anterior-superior: y; left-posterior-superior,
// scanner-xyz and the others: as they are); without a space or its directions, the `spacings` (a
// negative one reverses its axis) with the origin at 0.
Affine nrrd_affine(const Nrrd& nrrd, VolumeFileInfo& info) {
  Affine a;
  const auto has_direction = [&](unsigned ax) { return std::isfinite(nrrd.axis[ax].spaceDirection[0]); };
  if (nrrd.spaceDim == 0 || !(has_direction(0) || has_direction(1) || has_direction(2))) {
    std::array<double, 3> steps{1, 1, 1};
    for (unsigned ax = 0; ax < 3; ++ax)
      if (std::isfinite(nrrd.axis[ax].spacing)) steps[ax] = nrrd.axis[ax].spacing;
    if (nrrd.spaceDim > 0) info.notes.push_back("a space without space directions: the spacings are taken as they are, from 0");
    return Affine::diagonal(steps, {0, 0, 0});
  }
  if (nrrd.spaceDim != 3)
    throw Error("NRRD space dimension " + std::to_string(nrrd.spaceDim) + " (expected 3: a volume's space directions in 3-D)");
  for (unsigned ax = 0; ax < 3; ++ax)
    for (unsigned d = 0; d < 3; ++d) {
      const double v = nrrd.axis[ax].spaceDirection[d];
      if (!std::isfinite(v))
        throw Error("NRRD space direction of axis " + std::to_string(ax) + " is not finite (expected three numbers, not 'none')");
      a.linear[d][ax] = v;
    }
  bool has_origin = true;
  for (unsigned d = 0; d < 3; ++d) has_origin = has_origin && std::isfinite(nrrd.spaceOrigin[d]);
  for (unsigned d = 0; d < 3; ++d) a.offset[d] = has_origin ? nrrd.spaceOrigin[d] : 0.0;  // "none" or unset: 0
  std::array<double, 3> to_lps{1, 1, 1};
  switch (nrrd.space) {
    case nrrdSpaceRightAnteriorSuperior:
    case nrrdSpaceRightAnteriorSuperiorTime: to_lps = {-1, -1, 1}; break;
    case nrrdSpaceLeftAnteriorSuperior:
    case nrrdSpaceLeftAnteriorSuperiorTime: to_lps = {1, -1, 1}; break;
    default: break;
  }
  for (int d = 0; d < 3; ++d) {
    for (double& v : a.linear[d]) v *= to_lps[d];
    a.offset[d] *= to_lps[d];
  }
  const char* name = airEnumStr(nrrdSpace, nrrd.space);
  info.notes.push_back(std::string("space ") + (nrrd.space == nrrdSpaceUnknown ? "not named" : name) +
                       (to_lps[0] < 0 || to_lps[1] < 0 ? ", turned into LPS" : ", taken as LPS"));
  return a;
}

}  // namespace

Volume load_nrrd_volume(const std::string& path, VolumeFileInfo& info, const std::string& confine_to) {
  return load_nrrd_volume(path, nullptr, nullptr, info, confine_to);
}

Volume load_nrrd_volume(const std::string& path, const SliceChooser* choose, WindowRead* read, VolumeFileInfo& info,
                        const std::string& confine_to) {
  const std::uint64_t file_bytes = io_detail::regular_file_size(path);
  const NrrdHeader header = parse_header(path, file_bytes);
  // teem resolves a relative data file against the header's directory, which it needs spelled out.
  const std::filesystem::path abs_path = std::filesystem::absolute(path);
  const Checked checked = check_header(header, abs_path, file_bytes, confine_to);
  // Raw and gzip data are read here, once, into the volume: teem parses the header and finds the data.
  // teem reads the rest itself into a buffer of its own (ascii, hex, and gzip data placed by a negative
  // byte skip, which only decompressing all of it finds), a gzip stream verified first.
  const bool gzip = header.encoding == nrrdEncodingTypeGzip;
  const bool direct = header.encoding == nrrdEncodingTypeRaw || (gzip && header.byte_skip >= 0);
  if (gzip && !direct) verify_gzip(checked, header);
  TeemRead teem = teem_load(abs_path, direct);

  // teem parsed the header itself; it must agree with what was checked above.
  const Nrrd& n = *teem.nrrd;
  if (n.dim != 3 || n.type != header.type || (!direct && !n.data))
    throw Error("teem read the NRRD differently from its header (dimension " + std::to_string(n.dim) + ")");
  for (unsigned a = 0; a < 3; ++a)
    if (n.axis[a].size != static_cast<std::size_t>(checked.dims[a]))
      throw Error("teem read NRRD size " + std::to_string(n.axis[a].size) + " on axis " + std::to_string(a) +
                  " but the header says " + std::to_string(checked.dims[a]));

  const std::array<int, 3> dims{static_cast<int>(checked.dims[0]), static_cast<int>(checked.dims[1]), static_cast<int>(checked.dims[2])};
  const Affine affine = nrrd_affine(n, info);
  const auto permutation = axis_permutation(affine);
  if (read) *read = WindowRead{0, !direct};
  // A window whose slices are the file's own (its z is the file's third axis, reversed or not) reads
  // only them.
  const FileWindow window = file_window(choose, dims, permutation);
  if (window.in_part && direct) {
    Volume slices(nrrd_storage_type(n.type), {dims[0], dims[1], window.count}, {1, 1, 1}, {0, 0, 0}, VoxelFill::Uninitialized);
    const std::uint64_t bytes = read_data_file(teem, abs_path, header, checked, window.file_first, slices);
    if (read) read->bytes_read = bytes;
    teem = TeemRead{};
    return place_window(std::move(slices), affine, dims, *permutation, window, info);
  }
  Volume volume(nrrd_storage_type(n.type), dims, {1, 1, 1}, {0, 0, 0}, VoxelFill::Uninitialized);  // both paths below fill every voxel
  if (read) read->bytes_read = file_bytes;
  if (direct) {
    const std::uint64_t bytes = read_data_file(teem, abs_path, header, checked, 0, volume);
    if (read && checked.data_path != abs_path) read->bytes_read = bytes;  // a detached header's data file
  } else {
    const auto* src = static_cast<const std::byte*>(teem.nrrd->data);  // teem has fixed the byte order
    const auto next = [&](std::byte* dst, std::size_t bytes) {
      std::memcpy(dst, src, bytes);
      src += bytes;
    };
    read_voxels(next, n.type, false, volume);
  }
  teem = TeemRead{};  // free teem's copy, if any, before the range pass
  volume = keep_chosen_slices(place_volume(std::move(volume), affine, info), choose, window, read);
  volume.recompute_range();  // rejects NaN/inf voxels and gives the volume its range
  return volume;
}

}  // namespace penumbra
