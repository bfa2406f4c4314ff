// VTK XML ImageData (.vti): one <Piece> of <PointData> whose scalars (the array the Scalars attribute
// names, else the first one-component array) become the volume. Arrays may be ascii, base64
// ("binary") or appended (raw or base64), each uncompressed (a byte-count header) or
// vtkZLibDataCompressor blocks (a block table, then zlib streams), in either byte order, with 32- or
// 64-bit headers. The tags are read by a small scanner written here, not an XML parser: raw appended
// data makes the file ill-formed XML after <AppendedData encoding="raw">, so scanning stops at that tag.
// Every size the file states is checked against what the data can hold before anything is allocated.
// Direction: an axis-aligned diagonal of ±1 (and negative spacing) is honoured by reversing those axes
// so that the volume's world box matches VTK's; any other Direction is noted and ignored.
#include <fcntl.h>
#include <sys/mman.h>
#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/text_fields.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/io/volume_placement.h"
#include "penumbra/data/io/vtk_image_data.h"

namespace penumbra {

namespace {

using io_detail::bytes_str;
using io_detail::printable;
using io_detail::VtkType;

// ---- a small XML tag scanner -------------------------------------------------------------------

struct XmlTag {
  std::string_view name;
  std::vector<std::pair<std::string_view, std::string_view>> attributes;
  bool closing = false, empty = false;  // </name>, <name/>
  std::size_t begin = 0, end = 0;       // offsets of '<' and just past '>'

  std::optional<std::string_view> get(std::string_view key) const {
    for (const auto& [k, v] : attributes)
      if (k == key) return v;
    return std::nullopt;
  }
};

bool is_blank(char c) { return c == ' ' || c == '\t' || c == '\n' || c == '\r'; }

// Tags in document order, skipping text, comments, <?...?> and <!...>.
class XmlScanner {
public:
  explicit XmlScanner(std::string_view text) : text_(text) {}

  bool next(XmlTag& tag) {
    for (;;) {
      const std::size_t lt = text_.find('<', pos_);
      if (lt == std::string_view::npos) return false;
      if (text_.compare(lt, 4, "<!--") == 0) {
        const std::size_t end = text_.find("-->", lt + 4);
        if (end == std::string_view::npos) throw error(lt, "a comment that never ends");
        pos_ = end + 3;
      } else if (lt + 1 < text_.size() && (text_[lt + 1] == '?' || text_[lt + 1] == '!')) {
        const std::size_t end = text_.find('>', lt);
        if (end == std::string_view::npos) throw error(lt, "a declaration that never ends");
        pos_ = end + 1;
      } else {
        parse_tag(lt, tag);
        return true;
      }
    }
  }

private:
  Error error(std::size_t at, const std::string& what) const {
    return Error("XML at byte " + std::to_string(at) + ": " + what);
  }
  void skip_blanks(std::size_t& i) const {
    while (i < text_.size() && is_blank(text_[i])) ++i;
  }
  std::string_view word(std::size_t& i) const {
    const std::size_t start = i;
    while (i < text_.size() && !is_blank(text_[i]) && text_[i] != '>' && text_[i] != '/' && text_[i] != '=') ++i;
    return text_.substr(start, i - start);
  }

  void parse_tag(std::size_t lt, XmlTag& tag) {
    tag = XmlTag{};
    tag.begin = lt;
    std::size_t i = lt + 1;
    if (i < text_.size() && text_[i] == '/') tag.closing = true, ++i;
    tag.name = word(i);
    if (tag.name.empty()) throw error(lt, "a '<' without a tag name");
    const std::string name = printable(tag.name, 40);
    for (;;) {
      skip_blanks(i);
      if (i >= text_.size()) throw error(lt, "tag <" + name + "> is not closed with '>'");
      if (text_[i] == '>') {
        ++i;
        break;
      }
      if (text_[i] == '/') {
        if (i + 1 >= text_.size() || text_[i + 1] != '>') throw error(i, "'/' inside tag <" + name + "> (expected '/>')");
        tag.empty = true;
        i += 2;
        break;
      }
      const std::string_view key = word(i);
      skip_blanks(i);
      if (key.empty() || i >= text_.size() || text_[i] != '=')
        throw error(i, "attribute '" + printable(key, 40) + "' of <" + name + "> has no '=value'");
      ++i;
      skip_blanks(i);
      if (i >= text_.size() || (text_[i] != '"' && text_[i] != '\''))
        throw error(i, "attribute '" + printable(key, 40) + "' of <" + name + "> has no quoted value");
      const std::size_t close = text_.find(text_[i], i + 1);
      if (close == std::string_view::npos) throw error(i, "attribute '" + printable(key, 40) + "' of <" + name + "> has no closing quote");
      tag.attributes.emplace_back(key, text_.substr(i + 1, close - i - 1));
      i = close + 1;
    }
    tag.end = pos_ = i;
  }

  std::string_view text_;
  std::size_t pos_ = 0;
};

// ---- where array bytes come from: raw bytes or base64 text -------------------------------------

class ByteSource {
public:
  virtual ~ByteSource() = default;
  virtual void read(std::byte* out, std::size_t n) = 0;  // Error when fewer than n bytes remain
  virtual void skip(std::uint64_t n) = 0;                // as read, the bytes dropped
  virtual std::uint64_t remaining() const = 0;            // at most this many bytes remain
  virtual std::uint64_t touched() const = 0;              // the file's bytes looked at so far
};

class RawSource final : public ByteSource {
public:
  explicit RawSource(std::string_view bytes) : bytes_(bytes) {}
  void read(std::byte* out, std::size_t n) override {
    if (n > bytes_.size() - pos_)
      throw Error("raw appended data ends after " + bytes_str(bytes_.size()) + " but " + bytes_str(pos_ + n) +
                  " are needed (truncated file or lying sizes)");
    std::memcpy(out, bytes_.data() + pos_, n);
    pos_ += n;
    touched_ += n;
  }
  void skip(std::uint64_t n) override {
    if (n > bytes_.size() - pos_)
      throw Error("raw appended data ends after " + bytes_str(bytes_.size()) + " but " + bytes_str(pos_ + n) +
                  " are needed (truncated file or lying sizes)");
    pos_ += static_cast<std::size_t>(n);
  }
  std::uint64_t remaining() const override { return bytes_.size() - pos_; }
  std::uint64_t touched() const override { return touched_; }

private:
  std::string_view bytes_;
  std::size_t pos_ = 0;
  std::uint64_t touched_ = 0;
};

// Base64 decoded as it is read, so that separately encoded pieces (VTK encodes a zlib header apart
// from its blocks) decode in sequence: a padded group ends one piece and the next group starts another.
class Base64Source final : public ByteSource {
public:
  explicit Base64Source(std::string_view text) : text_(text) {}
  void read(std::byte* out, std::size_t n) override {
    for (std::size_t done = 0; done < n;) {
      if (have_ == used_) decode_group();
      const std::size_t take = std::min<std::size_t>(n - done, have_ - used_);
      std::memcpy(out + done, group_.data() + used_, take);
      used_ += take, done += take;
    }
  }
  // Base64 has no index (blanks and a separately encoded piece's padding may lie anywhere in it): where the
  // text to skip holds neither (VTK writes appended data without them) it is stepped over, four characters
  // for three bytes; otherwise the skipped bytes are decoded and dropped.
  void skip(std::uint64_t n) override {
    const std::size_t rest = static_cast<std::size_t>(std::min<std::uint64_t>(n, have_ - used_));  // of the group decoded last
    used_ += rest;
    n -= rest;
    if (n > 0 && have_ == used_) {
      const std::size_t chars = static_cast<std::size_t>(std::min<std::uint64_t>(n / 3, (text_.size() - pos_) / 4)) * 4;
      const std::string_view span = text_.substr(pos_, chars);
      if (std::none_of(span.begin(), span.end(), [](char c) { return is_blank(c) || c == '='; })) {
        pos_ += chars;
        decoded_ += chars / 4 * 3;
        n -= chars / 4 * 3;
      }
    }
    std::array<std::byte, 3 << 10> scratch;
    for (std::uint64_t done = 0; done < n;) {
      const std::size_t take = static_cast<std::size_t>(std::min<std::uint64_t>(n - done, scratch.size()));
      read(scratch.data(), take);
      done += take;
    }
  }
  std::uint64_t remaining() const override { return (text_.size() - pos_) / 4 * 3 + (have_ - used_); }
  std::uint64_t touched() const override { return pos_; }

private:
  static int value(char c) {
    if (c >= 'A' && c <= 'Z') return c - 'A';
    if (c >= 'a' && c <= 'z') return c - 'a' + 26;
    if (c >= '0' && c <= '9') return c - '0' + 52;
    return c == '+' ? 62 : c == '/' ? 63 : c == '=' ? 64 : -1;
  }
  void decode_group() {
    std::array<int, 4> v{};
    std::size_t k = 0;
    for (; k < 4 && pos_ < text_.size(); ++pos_) {
      const char c = text_[pos_];
      if (is_blank(c)) continue;
      v[k] = value(c);
      if (v[k] < 0)
        throw Error("bad base64 data: character '" + printable(std::string_view(&c, 1)) + "' (byte " +
                    std::to_string(static_cast<unsigned char>(c)) + ") after " + bytes_str(decoded_) + " decoded");
      ++k;
    }
    if (k < 4)
      throw Error(k == 0 ? "base64 data ends after " + bytes_str(decoded_) + " (truncated data or lying sizes)"
                         : "base64 data ends inside a 4-character group (truncated)");
    if (v[0] == 64 || v[1] == 64 || (v[2] == 64 && v[3] != 64))
      throw Error("bad base64 data: misplaced '=' padding after " + bytes_str(decoded_) + " decoded");
    const unsigned bits = static_cast<unsigned>(v[0]) << 18 | static_cast<unsigned>(v[1]) << 12 |
                          static_cast<unsigned>(v[2] & 63) << 6 | static_cast<unsigned>(v[3] & 63);
    group_ = {std::byte(bits >> 16 & 0xff), std::byte(bits >> 8 & 0xff), std::byte(bits & 0xff)};
    have_ = v[2] == 64 ? 1 : v[3] == 64 ? 2 : 3;
    used_ = 0;
    decoded_ += have_;
  }

  std::string_view text_;
  std::size_t pos_ = 0;
  std::array<std::byte, 3> group_{};
  std::size_t have_ = 0, used_ = 0;
  std::uint64_t decoded_ = 0;
};

// The file mapped read-only, so that reading a window of slices reads only the pages that hold them (and
// a whole read holds the file's bytes only as the page cache does, not in a copy beside the voxels). A
// file cut short by another program while it is being read would stop the process (SIGBUS), as any mapped
// reader would; a file cut short before it is read is an error like any other (its sizes are checked).
class MappedFile {
public:
  MappedFile(const std::string& path, std::uint64_t bytes) : size_(static_cast<std::size_t>(bytes)) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
    if (fd < 0) throw Error("cannot open the file");
    data_ = ::mmap(nullptr, size_, PROT_READ, MAP_PRIVATE, fd, 0);
    ::close(fd);
    if (data_ == MAP_FAILED) throw Error("cannot map the file (" + bytes_str(bytes) + ") into memory");
  }
  ~MappedFile() { ::munmap(data_, size_); }
  MappedFile(const MappedFile&) = delete;
  MappedFile& operator=(const MappedFile&) = delete;
  std::string_view text() const { return {static_cast<const char*>(data_), size_}; }

private:
  void* data_ = nullptr;
  std::size_t size_ = 0;
};

// ---- the file's structure ----------------------------------------------------------------------

struct ArrayInfo {
  std::string name;
  VtkType type = VtkType::UInt8;
  std::size_t components = 1;
  std::string format;        // ascii, binary, appended
  std::uint64_t offset = 0;  // appended: into the appended data
  std::string_view content;  // ascii, binary: the text inside <DataArray>
};

struct VtiFile {
  bool big_endian = false, header64 = false, zlib = false;
  std::optional<std::array<std::int64_t, 6>> whole_extent, piece_extent;
  std::array<double, 3> origin{0, 0, 0}, spacing{1, 1, 1};
  std::array<double, 9> direction{1, 0, 0, 0, 1, 0, 0, 0, 1};
  int pieces = 0;
  std::optional<std::string> scalars;  // the PointData Scalars attribute
  std::vector<ArrayInfo> point_arrays;
  std::size_t cell_arrays = 0;
  std::optional<std::string_view> appended;  // after the '_' marker
  bool appended_base64 = false;
};

template <std::size_t N>
std::array<double, N> numbers(std::string_view value, const std::string& what) {
  const auto fields = io_detail::split_fields(value);
  std::array<double, N> out{};
  if (fields.size() != N) throw Error(what + " has " + std::to_string(fields.size()) + " numbers (expected " + std::to_string(N) + ")");
  for (std::size_t i = 0; i < N; ++i)
    if (!io_detail::parse_number(fields[i], out[i]) || !std::isfinite(out[i]))
      throw Error(what + " value '" + printable(fields[i], 40) + "' is not a finite number");
  return out;
}

std::array<std::int64_t, 6> extent(std::string_view value, const std::string& what) {
  const auto v = numbers<6>(value, what);
  std::array<std::int64_t, 6> e{};
  for (std::size_t i = 0; i < 6; ++i) {
    if (v[i] != std::floor(v[i]) || std::abs(v[i]) > 1e9) throw Error(what + " value " + num(v[i]) + " is not an index");
    e[i] = static_cast<std::int64_t>(v[i]);
  }
  for (std::size_t a = 0; a < 3; ++a)
    if (e[2 * a + 1] < e[2 * a])
      throw Error(what + " \"" + printable(value, 80) + "\" is empty along axis " + std::to_string(a) + " (expected min <= max)");
  return e;
}

std::uint64_t whole_number(std::string_view value, std::uint64_t max, const std::string& what) {
  double v = 0;
  if (!io_detail::parse_number(value, v) || v < 0 || v != std::floor(v) || v > static_cast<double>(max))
    throw Error(what + " '" + printable(value, 40) + "' is not a whole number from 0 to " + std::to_string(max));
  return static_cast<std::uint64_t>(v);
}

void read_root(const XmlTag& tag, VtiFile& f) {
  if (tag.name != "VTKFile" || tag.closing)
    throw Error("not a VTK XML file (the first element is <" + printable(tag.name, 40) + ">, expected <VTKFile>)");
  const std::string type(tag.get("type").value_or(""));
  if (type != "ImageData")
    throw Error("VTKFile type is '" + printable(type, 40) + "' (expected ImageData; other VTK datasets are not volumes)");
  const std::string order(tag.get("byte_order").value_or("LittleEndian"));
  if (order != "LittleEndian" && order != "BigEndian")
    throw Error("byte_order '" + printable(order, 40) + "' (expected LittleEndian or BigEndian)");
  f.big_endian = order == "BigEndian";
  const std::string header(tag.get("header_type").value_or("UInt32"));
  if (header != "UInt32" && header != "UInt64") throw Error("header_type '" + printable(header, 40) + "' (expected UInt32 or UInt64)");
  f.header64 = header == "UInt64";
  const std::string compressor(tag.get("compressor").value_or(""));
  if (!compressor.empty() && compressor != "vtkZLibDataCompressor")
    throw Error("compressor '" + printable(compressor, 40) + "' is not supported (expected vtkZLibDataCompressor or none)");
  f.zlib = !compressor.empty();
}

ArrayInfo read_array_tag(const XmlTag& tag) {
  ArrayInfo a;
  a.name = std::string(tag.get("Name").value_or(""));
  const std::string what = "DataArray '" + printable(a.name, 60) + "'";
  const std::string type(tag.get("type").value_or(""));
  const auto t = io_detail::vtk_type_from_xml(type);
  if (!t)
    throw Error(what + " has type '" + printable(type, 40) +
                "' (expected Int8, UInt8, Int16, UInt16, Int32, UInt32, Int64, UInt64, Float32 or Float64)");
  a.type = *t;
  if (const auto c = tag.get("NumberOfComponents")) a.components = whole_number(*c, 1024, what + " NumberOfComponents");
  if (a.components == 0) throw Error(what + " has NumberOfComponents 0");
  a.format = std::string(tag.get("format").value_or(""));
  if (a.format != "ascii" && a.format != "binary" && a.format != "appended")
    throw Error(what + " has format '" + printable(a.format, 40) + "' (expected ascii, binary or appended)");
  if (a.format == "appended") a.offset = whole_number(tag.get("offset").value_or(""), 1ull << 50, what + " offset");
  return a;
}

VtiFile scan(std::string_view text) {
  VtiFile f;
  XmlScanner xml(text);
  XmlTag tag;
  enum class Section { None, Point, Cell } section = Section::None;
  bool root = false;
  // index in point_arrays of an open <DataArray>, or kNoArray (a sentinel rather than an optional:
  // GCC 12 warns about an optional<size_t> here that it cannot see is set)
  constexpr std::size_t kNoArray = static_cast<std::size_t>(-1);
  std::size_t open_array = kNoArray;
  std::size_t content_begin = 0;
  while (xml.next(tag)) {
    if (!root) {
      read_root(tag, f);
      root = true;
    } else if (tag.name == "DataArray") {
      if (tag.closing) {
        if (open_array != kNoArray) f.point_arrays[open_array].content = text.substr(content_begin, tag.begin - content_begin);
        open_array = kNoArray;
      } else if (section == Section::Point && f.pieces == 1) {
        f.point_arrays.push_back(read_array_tag(tag));
        if (!tag.empty) open_array = f.point_arrays.size() - 1, content_begin = tag.end;
      } else if (section == Section::Cell) {
        ++f.cell_arrays;
      }
    } else if (open_array != kNoArray) {
      content_begin = tag.end;  // <InformationKey> and the like come before the values
    } else if (tag.name == "ImageData" && !tag.closing) {
      if (const auto e = tag.get("WholeExtent")) f.whole_extent = extent(*e, "WholeExtent");
      if (const auto o = tag.get("Origin")) f.origin = numbers<3>(*o, "Origin");
      if (const auto s = tag.get("Spacing")) f.spacing = numbers<3>(*s, "Spacing");
      if (const auto d = tag.get("Direction")) f.direction = numbers<9>(*d, "Direction");
    } else if (tag.name == "Piece" && !tag.closing) {
      if (++f.pieces == 1)
        if (const auto e = tag.get("Extent")) f.piece_extent = extent(*e, "Piece Extent");
    } else if (tag.name == "PointData" || tag.name == "CellData") {
      section = tag.closing || tag.empty ? Section::None : tag.name == "PointData" ? Section::Point : Section::Cell;
      if (tag.name == "PointData" && !tag.closing && f.pieces == 1)
        if (const auto s = tag.get("Scalars")) f.scalars = std::string(*s);
    } else if (tag.name == "AppendedData" && !tag.closing) {
      const std::string encoding(tag.get("encoding").value_or("base64"));
      if (encoding != "raw" && encoding != "base64")
        throw Error("AppendedData encoding '" + printable(encoding, 40) + "' (expected raw or base64)");
      f.appended_base64 = encoding == "base64";
      std::size_t i = tag.end;
      while (i < text.size() && is_blank(text[i])) ++i;
      if (tag.empty || i >= text.size() || text[i] != '_')
        throw Error("<AppendedData> is not followed by the '_' that starts its data");
      f.appended = text.substr(i + 1);
      break;  // raw data follows: no more XML to read
    }
  }
  if (!root) throw Error("not a VTK XML file (no <VTKFile> element)");
  return f;
}

// ---- reading one array -------------------------------------------------------------------------

std::uint64_t header_word(ByteSource& src, const VtiFile& f) {
  std::array<std::byte, 8> b{};
  const std::size_t n = f.header64 ? 8 : 4;
  src.read(b.data(), n);
  if (f.big_endian != (std::endian::native == std::endian::big)) std::reverse(b.begin(), b.begin() + static_cast<std::ptrdiff_t>(n));
  if (n == 4) {
    std::uint32_t v = 0;
    std::memcpy(&v, b.data(), 4);
    return v;
  }
  std::uint64_t v = 0;
  std::memcpy(&v, b.data(), 8);
  return v;
}

// The bytes [first, first + count) of an array of `want` bytes (its values, packed).
struct ByteRange {
  std::uint64_t first = 0, count = 0;
};

// Bytes `range` of a binary array: a byte count then the bytes, or a zlib block table then the blocks
// (only the blocks that hold the range are decompressed, the others skipped unread where the data is raw).
std::vector<std::byte> read_binary(ByteSource& src, const VtiFile& f, std::uint64_t want, ByteRange range, const std::string& need) {
  if (!f.zlib) {
    const std::uint64_t n = header_word(src, f);
    if (n != want) throw Error("its header says " + bytes_str(n) + " but " + need);
    if (src.remaining() < want) throw Error("its data has at most " + bytes_str(src.remaining()) + " but " + need + " (truncated file)");
    std::vector<std::byte> out(static_cast<std::size_t>(range.count));
    src.skip(range.first);
    src.read(out.data(), out.size());
    return out;
  }
  const std::uint64_t blocks = header_word(src, f), block = header_word(src, f), last = header_word(src, f);
  const std::uint64_t word = f.header64 ? 8 : 4;
  if (blocks > src.remaining() / word)
    throw Error("its zlib header claims " + std::to_string(blocks) + " blocks, more than the data could hold");
  if (blocks > 0 && (block == 0 || last > block))
    throw Error("its zlib header has block size " + std::to_string(block) + " and last block size " + std::to_string(last));
  const std::uint64_t last_size = last ? last : block;
  // (one block may be shorter than the block size: VTK writes a small array as one block of 32 KiB whose
  // last, and only, size is the array's)
  const bool fits = blocks == 0 ? want == 0
                                : last_size <= want && (blocks - 1) <= (want - last_size) / block && (blocks - 1) * block + last_size == want;
  if (!fits)
    throw Error("its zlib header describes " + std::to_string(blocks) + " blocks of " + bytes_str(block) + " (last " +
                bytes_str(last_size) + ") but " + need);
  std::vector<std::uint64_t> sizes(static_cast<std::size_t>(blocks));
  for (auto& s : sizes) s = header_word(src, f);
  std::uint64_t stored = 0;
  const std::uint64_t room = src.remaining();
  for (const std::uint64_t s : sizes) {
    if (s > room - stored)
      throw Error("its zlib block sizes add up to more than the " + bytes_str(room) + " of data left (truncated file or lying sizes)");
    stored += s;
  }
  if (!io_detail::deflate_could_hold(stored, want))
    throw Error("its zlib blocks hold " + bytes_str(stored) + ", too few to decompress to what " + need);
  std::vector<std::byte> out(static_cast<std::size_t>(range.count));
  std::vector<std::byte> packed, unpacked;
  const std::uint64_t range_end = range.first + range.count;
  for (std::size_t b = 0; b < sizes.size(); ++b) {
    const std::uint64_t begin = b * block, expect = b + 1 == sizes.size() ? last_size : block;
    if (begin >= range_end) break;  // past the range: never read
    if (begin + expect <= range.first) {  // before it
      src.skip(sizes[b]);
      continue;
    }
    packed.resize(static_cast<std::size_t>(sizes[b]));
    src.read(packed.data(), packed.size());
    // straight into the output when the block lies inside the range, else through a block of its own
    const bool inside = begin >= range.first && begin + expect <= range_end;
    if (!inside) unpacked.resize(static_cast<std::size_t>(expect));
    std::byte* target = inside ? out.data() + (begin - range.first) : unpacked.data();
    uLongf got = static_cast<uLongf>(expect);
    const int rc = uncompress(reinterpret_cast<Bytef*>(target), &got, reinterpret_cast<const Bytef*>(packed.data()),
                              static_cast<uLong>(packed.size()));
    if (rc != Z_OK || got != expect)
      throw Error("zlib block " + std::to_string(b) + " of " + std::to_string(sizes.size()) + " is corrupt (zlib: " +
                  (rc == Z_OK ? "it decompresses to " + bytes_str(got) + ", expected " + bytes_str(expect)
                   : rc == Z_BUF_ERROR ? std::string("incomplete or larger than the block size") : std::string(zError(rc))) + ")");
    if (!inside) {
      const std::uint64_t lo = std::max(begin, range.first), hi = std::min(begin + expect, range_end);
      std::memcpy(out.data() + (lo - range.first), unpacked.data() + (lo - begin), static_cast<std::size_t>(hi - lo));
    }
  }
  return out;
}

// Bytes `range` of the array's packed values (all of them for ASCII text, which has no places).
// `touched`: the file's bytes it looked at.
std::vector<std::byte> read_array(const VtiFile& f, const ArrayInfo& a, std::size_t values, ByteRange range, const std::string& need,
                                  std::uint64_t& touched) {
  const std::uint64_t want = std::uint64_t{values} * io_detail::vtk_type_size(a.type);
  touched = a.content.size();
  if (a.format == "ascii") {
    if (a.content.size() / 2 + 1 < values) throw Error("its ASCII text is too short: " + need);
    std::vector<std::byte> out(static_cast<std::size_t>(want));
    const std::size_t end = io_detail::parse_ascii_values(a.content, a.type, values, out.data());
    if (!io_detail::trim(a.content.substr(end)).empty())
      throw Error("its ASCII text has more than the " + std::to_string(values) + " values " + need);
    return out;
  }
  const auto binary = [&](ByteSource&& src) {
    std::vector<std::byte> out = read_binary(src, f, want, range, need);
    touched = src.touched();
    return out;
  };
  if (a.format == "binary") return binary(Base64Source(a.content));
  if (!f.appended) throw Error("it is format=\"appended\" but the file has no <AppendedData>");
  if (a.offset > f.appended->size())
    throw Error("its offset " + std::to_string(a.offset) + " is past the end of the appended data (" + bytes_str(f.appended->size()) + ")");
  const std::string_view data = f.appended->substr(static_cast<std::size_t>(a.offset));
  if (f.appended_base64) return binary(Base64Source(data));
  return binary(RawSource(data));
}

const ArrayInfo& choose_array(const VtiFile& f, std::vector<std::string>& notes) {
  if (f.point_arrays.empty()) {
    if (f.cell_arrays > 0)
      throw Error("the file has only cell data (" + std::to_string(f.cell_arrays) +
                  " arrays in <CellData>); penumbra reads point data (one value per grid point)");
    throw Error("the file has no <PointData> <DataArray>");
  }
  if (f.scalars) {
    for (const auto& a : f.point_arrays)
      if (a.name == *f.scalars) return a;
    throw Error("PointData Scalars names '" + printable(*f.scalars, 60) + "' but no DataArray has that Name");
  }
  for (const auto& a : f.point_arrays)
    if (a.components == 1) {
      if (f.point_arrays.size() > 1) notes.push_back("no Scalars attribute: the first one-component array, '" + a.name + "', loaded");
      return a;
    }
  return f.point_arrays.front();
}

}  // namespace

Volume load_vti_volume(const std::string& path, VolumeFileInfo* info) { return load_vti_volume(path, info, nullptr, nullptr); }

Volume load_vti_volume(const std::string& path, VolumeFileInfo* info, const SliceChooser* choose, WindowRead* read) {
  VolumeFileInfo local;
  VolumeFileInfo& out = info ? *info : local;
  out.format = "vti";
  if (read) *read = WindowRead{};
  const std::uint64_t file_bytes = io_detail::regular_file_size(path);
  if (file_bytes == 0) throw Error("empty file (expected a VTK XML ImageData file)");
  const MappedFile file(path, file_bytes);
  const VtiFile f = scan(file.text());

  if (f.pieces == 0) throw Error("no <Piece> in the ImageData");
  if (f.pieces > 1)
    throw Error(std::to_string(f.pieces) + " pieces in the ImageData (penumbra reads single-piece files; merge the pieces in VTK or ParaView)");
  if (!f.piece_extent && !f.whole_extent) throw Error("neither the Piece nor the ImageData has an extent");
  const auto e = f.piece_extent ? *f.piece_extent : *f.whole_extent;
  if (f.whole_extent && *f.whole_extent != e) out.notes.push_back("the Piece Extent, not the WholeExtent, is loaded");
  const std::array<std::int64_t, 3> dims{e[1] - e[0] + 1, e[3] - e[2] + 1, e[5] - e[4] + 1};
  const std::string dims_text = std::to_string(dims[0]) + "x" + std::to_string(dims[1]) + "x" + std::to_string(dims[2]);
  const std::size_t count = with_context("extent " + dims_text, [&] { return checked_voxel_count(dims); });

  const ArrayInfo& array = choose_array(f, out.notes);
  const std::uint64_t values = std::uint64_t{count} * array.components;
  const std::string need = "the extent " + dims_text + " x " + std::to_string(array.components) + " component(s) of " +
                           io_detail::vtk_type_name(array.type) + " needs " + std::to_string(values) + " values, " +
                           bytes_str(values * io_detail::vtk_type_size(array.type));

  // World = Origin + Direction · (index · Spacing), the index counted from the extent's start; VTK's
  // world has no anatomical frame and is taken as it is. The voxels are placed by it (volume_placement.h).
  Affine affine;
  for (std::size_t r = 0; r < 3; ++r) {
    affine.offset[r] = f.origin[r];
    for (std::size_t c = 0; c < 3; ++c) {
      affine.linear[r][c] = f.direction[r * 3 + c] * f.spacing[c];
      affine.offset[r] += affine.linear[r][c] * static_cast<double>(e[2 * c]);
    }
  }
  // A window whose slices are the file's own reads only their bytes of a binary array (ASCII text has no
  // places: it is read whole and cut).
  const std::array<int, 3> d{static_cast<int>(dims[0]), static_cast<int>(dims[1]), static_cast<int>(dims[2])};
  const auto permutation = axis_permutation(affine);
  const FileWindow window = file_window(choose, d, permutation);
  const bool in_part = window.in_part && array.format != "ascii";
  const std::uint64_t slice_bytes = std::uint64_t{count} / static_cast<std::uint64_t>(d[2]) * array.components * io_detail::vtk_type_size(array.type);
  const ByteRange range = in_part ? ByteRange{window.file_first * slice_bytes, window.count * slice_bytes} : ByteRange{0, values * io_detail::vtk_type_size(array.type)};
  std::uint64_t touched = 0;
  const std::vector<std::byte> data = with_context("DataArray '" + printable(array.name, 60) + "'", [&] {
    return read_array(f, array, static_cast<std::size_t>(values), range, need, touched);
  });
  if (read) read->bytes_read = touched;
  Volume volume(io_detail::vtk_volume_type(array.type), {d[0], d[1], in_part ? window.count : d[2]}, {1, 1, 1}, {0, 0, 0},
                VoxelFill::Uninitialized);
  io_detail::store_vtk_samples(data.data(), array.type, f.big_endian, array.components, volume, out.notes);
  if (in_part) return place_window(std::move(volume), affine, d, *permutation, window, out);
  volume = keep_chosen_slices(place_volume(std::move(volume), affine, out), choose, window, read);
  volume.recompute_range();  // rejects NaN/inf voxels and gives the volume its range
  return volume;
}

}  // namespace penumbra
