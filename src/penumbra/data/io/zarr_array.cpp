// Zarr arrays, v2 and v3: metadata, chunk keys, shards and codecs (zarr_array.h).
#include "penumbra/data/io/zarr_array.h"

#include <blosc.h>
#include <zlib.h>
#include <zstd.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>

#include "penumbra/core/error.h"
#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/text_fields.h"

namespace penumbra::io_detail {

namespace {

namespace fs = std::filesystem;

constexpr std::uint64_t kMaxMetadataBytes = 1u << 20;
constexpr std::uint64_t kNoChunk = std::numeric_limits<std::uint64_t>::max();  // a shard index entry of a chunk not stored

ZarrDType parse_v2_dtype(const nlohmann::json& j) {
  if (!j.is_string()) throw Error("\"dtype\" is " + j.dump() + " (expected a string such as \"<u2\"; structured dtypes are not volumes)");
  const std::string s = j.get<std::string>();
  if (s.size() < 3 || (s[0] != '<' && s[0] != '>' && s[0] != '|')) throw Error("dtype \"" + printable(s) + "\" (expected e.g. \"<u2\")");
  ZarrDType d;
  d.big_endian = s[0] == '>';
  d.kind = s[1];
  const std::string digits = s.substr(2);
  d.size = digits == "1" ? 1 : digits == "2" ? 2 : digits == "4" ? 4 : digits == "8" ? 8 : 0;
  const bool ok = (d.kind == 'u' || d.kind == 'i') ? d.size > 0 : (d.kind == 'f' && (d.size == 4 || d.size == 8));
  if (!ok) throw Error("dtype \"" + printable(s) + "\" is not supported (expected an integer of 1-8 bytes, float32 or float64)");
  return d;
}

ZarrDType parse_v3_data_type(const nlohmann::json& j) {
  const std::string s = j.is_string() ? j.get<std::string>() : j.dump();
  for (const auto& [name, kind, size] : std::initializer_list<std::tuple<const char*, char, int>>{
           {"uint8", 'u', 1}, {"uint16", 'u', 2}, {"uint32", 'u', 4}, {"uint64", 'u', 8}, {"int8", 'i', 1}, {"int16", 'i', 2},
           {"int32", 'i', 4}, {"int64", 'i', 8}, {"float32", 'f', 4}, {"float64", 'f', 8}})
    if (s == name) return ZarrDType{kind, size, false};
  throw Error("data_type " + printable(s) + " is not supported (expected an integer of 1-8 bytes, float32 or float64)");
}

double parse_fill(const nlohmann::json& fill) {
  if (fill.is_number()) return fill.get<double>();
  if (fill.is_null()) return 0;
  if (fill.is_string()) {
    const std::string s = fill.get<std::string>();
    if (s == "NaN") return std::numeric_limits<double>::quiet_NaN();
    if (s == "Infinity") return std::numeric_limits<double>::infinity();
    if (s == "-Infinity") return -std::numeric_limits<double>::infinity();
  }
  throw Error("fill_value " + fill.dump() + " (expected a number, \"NaN\", \"Infinity\", \"-Infinity\" or null)");
}

std::vector<std::int64_t> whole_numbers(const nlohmann::json& j, const std::string& key, std::int64_t least) {
  if (!j.is_array() || j.empty()) throw Error("\"" + key + "\" missing or not a list");
  std::vector<std::int64_t> out;
  for (const auto& v : j) {
    if (!v.is_number_integer() || v.get<std::int64_t>() < least || v.get<std::int64_t>() > (std::int64_t{1} << 40))
      throw Error("\"" + key + "\" holds " + v.dump() + " (expected whole numbers)");
    out.push_back(v.get<std::int64_t>());
  }
  return out;
}

// The array's metadata file `name` in `folder`: a JSON object of zarr_format `format`, the rest read by
// `parse` (Errors name the file).
ZarrArray read_metadata(const fs::path& folder, const char* name, int format, void (*parse)(const nlohmann::json&, ZarrArray&)) {
  const fs::path meta = folder / name;
  const nlohmann::json j = read_zarr_json(meta);
  return with_context(meta.string(), [&] {
    if (!j.is_object()) throw Error("expected a JSON object");
    if (json_field(j, "zarr_format") != format)
      throw Error("zarr_format " + json_field(j, "zarr_format").dump() + " (expected " + std::to_string(format) + ")");
    ZarrArray a;
    a.folder = folder;
    a.format = format;
    parse(j, a);
    return a;
  });
}

void parse_v2(const nlohmann::json& j, ZarrArray& a) {
  a.shape = whole_numbers(json_field(j, "shape"), "shape", 0);
  a.chunks = whole_numbers(json_field(j, "chunks"), "chunks", 1);
  if (a.shape.size() != a.chunks.size()) throw Error("\"shape\" and \"chunks\" have different lengths");
  a.dtype = parse_v2_dtype(json_field(j, "dtype"));
  if (j.contains("filters") && !j["filters"].is_null() && !j["filters"].empty())
    throw Error("filters " + j["filters"].dump() + " are not supported (penumbra decodes a compressor only)");
  const std::string order = json_string(j, "order", std::string("C"));
  if (order != "C" && order != "F") throw Error("order \"" + printable(order) + "\" (expected \"C\" or \"F\")");
  a.fortran = order == "F";
  const std::string sep = json_string(j, "dimension_separator", std::string("."));
  if (sep != "." && sep != "/") throw Error("dimension_separator \"" + printable(sep) + "\" (expected \".\" or \"/\")");
  a.separator = sep[0];
  a.fill = parse_fill(json_field(j, "fill_value"));
  const nlohmann::json compressor = json_field(j, "compressor");
  if (compressor.is_object()) {
    const std::string id = json_string(compressor, "id", std::string());
    if (id != "blosc" && id != "zlib" && id != "gzip" && id != "zstd")
      throw Error("compressor \"" + printable(id) + "\" is not supported (expected blosc, zlib, gzip, zstd or none)");
    a.codecs.push_back(id);
  } else if (!compressor.is_null()) {
    throw Error("compressor " + compressor.dump() + " (expected null or {\"id\": ...})");
  }
}

// What a v3 codec chain says: the order, the byte order, the bytes-to-bytes codecs, and a shard's
// inner chain when the chain is sharding_indexed.
struct CodecChain {
  bool fortran = false, big_endian = false, sharded = false;
  std::vector<std::string> codecs;
  std::vector<std::int64_t> inner_chunks;
  bool index_at_end = true, index_crc32c = false;
  std::shared_ptr<CodecChain> inner;
};

std::string codec_name(const nlohmann::json& c) {
  if (!c.is_object() || !c.contains("name") || !c["name"].is_string()) throw Error("a codec " + c.dump() + " (expected {\"name\": ...})");
  return c["name"].get<std::string>();
}

CodecChain parse_codecs(const nlohmann::json& list, std::size_t rank, bool inside_shard) {
  if (!list.is_array() || list.empty()) throw Error("\"codecs\" missing or not a list");
  CodecChain chain;
  bool to_bytes = false;
  for (const auto& c : list) {
    const std::string name = codec_name(c);
    const nlohmann::json config = json_field(c, "configuration");
    if (!to_bytes && name == "transpose") {
      const nlohmann::json order = json_field(config, "order");
      std::vector<std::int64_t> o;
      if (order.is_array())
        for (const auto& v : order) o.push_back(v.is_number_integer() ? v.get<std::int64_t>() : -1);
      std::vector<std::int64_t> c_order(rank), f_order(rank);
      for (std::size_t k = 0; k < rank; ++k) c_order[k] = static_cast<std::int64_t>(k), f_order[k] = static_cast<std::int64_t>(rank - 1 - k);
      if (o == f_order) chain.fortran = !chain.fortran;
      else if (o != c_order) throw Error("a transpose of order " + order.dump() + " (expected the identity or the axes reversed, F order)");
    } else if (!to_bytes && name == "bytes") {
      const std::string endian = json_string(config, "endian", std::string("little"));
      if (endian != "little" && endian != "big") throw Error("the bytes codec's endian \"" + printable(endian) + "\" (expected little or big)");
      chain.big_endian = endian == "big";
      to_bytes = true;
    } else if (!to_bytes && name == "sharding_indexed") {
      if (inside_shard) throw Error("a shard inside a shard is not supported");
      chain.sharded = true;
      chain.inner_chunks = whole_numbers(json_field(config, "chunk_shape"), "sharding_indexed chunk_shape", 1);
      if (chain.inner_chunks.size() != rank) throw Error("sharding_indexed's chunk_shape has " + std::to_string(chain.inner_chunks.size()) + " axes, the array " + std::to_string(rank));
      chain.inner = std::make_shared<CodecChain>(parse_codecs(json_field(config, "codecs"), rank, true));
      const std::string where = json_string(config, "index_location", std::string("end"));
      if (where != "end" && where != "start") throw Error("sharding_indexed's index_location \"" + printable(where) + "\" (expected end or start)");
      chain.index_at_end = where == "end";
      const nlohmann::json index_codecs = json_field(config, "index_codecs");
      const CodecChain index = parse_codecs(index_codecs, 1, true);
      if (index.big_endian || index.sharded || (!index.codecs.empty() && index.codecs != std::vector<std::string>{"crc32c"}))
        throw Error("sharding_indexed's index_codecs " + index_codecs.dump() + " (expected bytes, little endian, and at most crc32c)");
      chain.index_crc32c = !index.codecs.empty();
      to_bytes = true;
    } else if (to_bytes && (name == "blosc" || name == "gzip" || name == "zstd" || name == "crc32c")) {
      if (chain.sharded) throw Error("the codec " + name + " after sharding_indexed is not supported");
      chain.codecs.push_back(name);
    } else {
      throw Error("the codec \"" + printable(name) + "\"" + (to_bytes ? " after the bytes codec" : " before the bytes codec") +
                  " is not supported (expected transpose, then bytes or sharding_indexed, then blosc, gzip, zstd or crc32c)");
    }
  }
  if (!to_bytes) throw Error("no bytes or sharding_indexed codec (the spec requires one)");
  return chain;
}

void parse_v3(const nlohmann::json& j, ZarrArray& a) {
  if (json_string(j, "node_type", std::string()) != "array") throw Error("node_type " + json_field(j, "node_type").dump() + " (expected \"array\")");
  if (j.contains("storage_transformers") && !j["storage_transformers"].empty()) throw Error("storage_transformers are not supported");
  a.shape = whole_numbers(json_field(j, "shape"), "shape", 0);
  const nlohmann::json grid = json_field(j, "chunk_grid");
  if (!grid.is_object() || json_string(grid, "name", std::string()) != "regular")
    throw Error("chunk_grid " + grid.dump() + " (expected {\"name\": \"regular\", ...})");
  const std::vector<std::int64_t> outer = whole_numbers(json_field(json_field(grid, "configuration"), "chunk_shape"), "chunk_shape", 1);
  if (outer.size() != a.shape.size()) throw Error("\"shape\" and \"chunk_shape\" have different lengths");
  a.dtype = parse_v3_data_type(json_field(j, "data_type"));
  a.fill = parse_fill(json_field(j, "fill_value"));
  const nlohmann::json keys = j.contains("chunk_key_encoding") ? json_field(j, "chunk_key_encoding") : nlohmann::json{{"name", "default"}};
  const std::string encoding = json_string(keys, "name", std::string());
  if (encoding != "default" && encoding != "v2") throw Error("chunk_key_encoding " + keys.dump() + " (expected default or v2)");
  const std::string sep = json_string(json_field(keys, "configuration"), "separator", encoding == "default" ? "/" : ".");
  if (sep != "." && sep != "/") throw Error("the chunk key separator \"" + printable(sep) + "\" (expected \".\" or \"/\")");
  a.separator = sep[0];
  a.key_prefix = encoding == "default" ? "c" + sep : "";
  const CodecChain chain = parse_codecs(json_field(j, "codecs"), a.shape.size(), false);
  const CodecChain& chunk = chain.sharded ? *chain.inner : chain;
  if (chain.sharded && chain.fortran) throw Error("a transpose before sharding_indexed is not supported");
  a.fortran = chunk.fortran;
  a.dtype.big_endian = chunk.big_endian && a.dtype.size > 1;
  a.codecs = chunk.codecs;
  if (chain.sharded) {
    a.shard = outer;
    a.chunks = chain.inner_chunks;
    for (std::size_t k = 0; k < outer.size(); ++k)
      if (outer[k] % a.chunks[k] != 0)
        throw Error("the shard shape " + nlohmann::json(outer).dump() + " is not a multiple of the inner chunk shape " + nlohmann::json(a.chunks).dump());
    a.index_at_end = chain.index_at_end;
    a.index_crc32c = chain.index_crc32c;
  } else {
    a.chunks = outer;
  }
}

std::vector<std::byte> read_range(std::ifstream& in, std::uint64_t offset, std::uint64_t size) {
  std::vector<std::byte> bytes(static_cast<std::size_t>(size));
  in.seekg(static_cast<std::streamoff>(offset));
  if (size > 0 && !in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(size))) throw Error("cannot read");
  return bytes;
}

void inflate_all(const std::vector<std::byte>& in, std::vector<std::byte>& out, bool gzip) {
  z_stream z{};
  if (inflateInit2(&z, gzip ? 16 + MAX_WBITS : MAX_WBITS) != Z_OK) throw Error("zlib could not start");
  z.next_in = reinterpret_cast<Bytef*>(const_cast<std::byte*>(in.data()));
  z.avail_in = static_cast<uInt>(in.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  const int status = inflate(&z, Z_FINISH);
  const std::size_t produced = out.size() - z.avail_out;
  inflateEnd(&z);
  if (status != Z_STREAM_END || produced != out.size())
    throw Error(std::string(gzip ? "gzip" : "zlib") + " data is corrupt or holds " + (status == Z_STREAM_END ? std::to_string(produced) : "other than") +
                " bytes (the chunk needs " + bytes_str(out.size()) + ")");
}

// Drops the CRC32C that ends `data`, after checking it.
void check_crc32c(std::vector<std::byte>& data, const std::string& what) {
  if (data.size() < 4) throw Error(what + " shorter than its CRC32C");
  std::uint32_t stored = 0;
  for (int b = 3; b >= 0; --b) stored = (stored << 8) | static_cast<std::uint32_t>(data[data.size() - 4 + static_cast<std::size_t>(b)]);
  data.resize(data.size() - 4);
  if (crc32c(data.data(), data.size()) != stored) throw Error(what + ": its CRC32C does not match (a corrupt file)");
}

// The chunk's bytes as stored before its bytes-to-bytes codecs: exactly `bytes` of them.
std::vector<std::byte> decode_stored(const ZarrArray& a, std::vector<std::byte> data, std::size_t bytes) {
  for (auto codec = a.codecs.rbegin(); codec != a.codecs.rend(); ++codec) {
    const bool last = codec + 1 == a.codecs.rend();
    const std::string& id = *codec;
    if (id == "crc32c") {
      check_crc32c(data, "the chunk");
      continue;
    }
    // a decompressor's output size is the chunk's only when it is the last decoder; v3 stores with two
    // compressors in a row are refused rather than guessed at
    if (!last) throw Error("the codecs " + nlohmann::json(a.codecs).dump() + " (a compressor must be the first bytes-to-bytes codec)");
    std::vector<std::byte> out(bytes);
    if (id == "blosc") {
      std::size_t nbytes = 0, cbytes = 0, block = 0;
      if (data.size() < BLOSC_MIN_HEADER_LENGTH) throw Error("a blosc chunk shorter than its header");
      blosc_cbuffer_sizes(data.data(), &nbytes, &cbytes, &block);
      if (nbytes != bytes || cbytes != data.size())
        throw Error("the blosc header says " + bytes_str(nbytes) + " from " + bytes_str(cbytes) + " (the chunk needs " + bytes_str(bytes) +
                    " from the file's " + bytes_str(data.size()) + ")");
      const int n = blosc_decompress_ctx(data.data(), out.data(), bytes, 1);
      if (n < 0 || static_cast<std::size_t>(n) != bytes) throw Error("blosc could not decode the chunk (corrupt, or a codec c-blosc lacks)");
    } else if (id == "zlib" || id == "gzip") {
      inflate_all(data, out, id == "gzip");
    } else {  // zstd
      const unsigned long long size = ZSTD_getFrameContentSize(data.data(), data.size());
      if (size == ZSTD_CONTENTSIZE_ERROR) throw Error("not a zstd frame");
      if (size != ZSTD_CONTENTSIZE_UNKNOWN && size != bytes)
        throw Error("the zstd frame holds " + bytes_str(size) + " (the chunk needs " + bytes_str(bytes) + ")");
      const std::size_t n = ZSTD_decompress(out.data(), bytes, data.data(), data.size());
      if (ZSTD_isError(n) || n != bytes) throw Error(std::string("zstd could not decode the chunk: ") + (ZSTD_isError(n) ? ZSTD_getErrorName(n) : "short"));
    }
    return out;
  }
  if (data.size() != bytes) throw Error(bytes_str(data.size()) + " (an uncompressed chunk of " + bytes_str(bytes) + " expected)");
  return data;
}

std::string chunk_key(const ZarrArray& a, const std::vector<std::int64_t>& index) {
  std::string key = a.key_prefix;
  for (std::size_t k = 0; k < index.size(); ++k) key += (k ? std::string(1, a.separator) : std::string()) + std::to_string(index[k]);
  return key;
}

}  // namespace

nlohmann::json read_zarr_json(const fs::path& file) {
  std::error_code ec;
  const auto size = fs::file_size(file, ec);
  if (ec) throw Error(file.string() + ": cannot read (" + ec.message() + ")");
  if (size > kMaxMetadataBytes) throw Error(file.string() + ": " + bytes_str(size) + " of metadata (at most 1 MiB expected)");
  std::ifstream in(file, std::ios::binary);
  std::string text(static_cast<std::size_t>(size), '\0');
  if (!in.read(text.data(), static_cast<std::streamsize>(size))) throw Error(file.string() + ": cannot read");
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw Error(file.string() + ": not JSON (" + e.what() + ")");
  }
}

const nlohmann::json& json_field(const nlohmann::json& j, const char* key) {
  static const nlohmann::json null;
  if (!j.is_object()) return null;
  const auto it = j.find(key);
  return it == j.end() ? null : *it;
}

std::string json_string(const nlohmann::json& j, const char* key, const std::string& fallback) {
  const nlohmann::json& v = json_field(j, key);
  if (v.is_null()) return fallback;
  if (!v.is_string()) throw Error("\"" + std::string(key) + "\" is " + v.dump() + " (expected a string)");
  return v.get<std::string>();
}

ZarrArray read_zarr_array(const fs::path& folder) {
  std::error_code ec;
  if (fs::exists(folder / "zarr.json", ec)) return read_metadata(folder, "zarr.json", 3, parse_v3);
  return read_metadata(folder, ".zarray", 2, parse_v2);
}

std::optional<std::vector<std::byte>> read_zarr_chunk(const ZarrArray& a, const std::vector<std::int64_t>& index, std::size_t bytes,
                                                      std::uint64_t& bytes_read) {
  std::error_code ec;
  if (a.shard.empty()) {
    const fs::path file = a.folder / chunk_key(a, index);
    if (!fs::is_regular_file(file, ec)) return std::nullopt;
    return with_context("chunk " + file.string(), [&] {
      std::ifstream in(file, std::ios::binary | std::ios::ate);
      if (!in) throw Error("cannot read");
      std::vector<std::byte> stored = read_range(in, 0, static_cast<std::uint64_t>(in.tellg()));
      bytes_read += stored.size();
      return decode_stored(a, std::move(stored), bytes);
    });
  }
  // the shard holding the chunk, and the chunk's place in the shard's index (C order over its chunks)
  std::vector<std::int64_t> shard_index(index.size());
  std::uint64_t entry = 0, entries = 1;
  for (std::size_t k = 0; k < index.size(); ++k) {
    const std::int64_t per_shard = a.shard[k] / a.chunks[k];
    shard_index[k] = index[k] / per_shard;
    entry = entry * static_cast<std::uint64_t>(per_shard) + static_cast<std::uint64_t>(index[k] % per_shard);
    entries *= static_cast<std::uint64_t>(per_shard);
  }
  const fs::path file = a.folder / chunk_key(a, shard_index);
  if (!fs::is_regular_file(file, ec)) return std::nullopt;
  return with_context("shard " + file.string(), [&]() -> std::optional<std::vector<std::byte>> {
    std::ifstream in(file, std::ios::binary | std::ios::ate);
    if (!in) throw Error("cannot read");
    const auto size = static_cast<std::uint64_t>(in.tellg());
    if (entries > (std::uint64_t{1} << 32)) throw Error("an index of " + std::to_string(entries) + " chunks");
    const std::uint64_t index_bytes = 16 * entries + (a.index_crc32c ? 4 : 0);
    if (size < index_bytes) throw Error(bytes_str(size) + ", shorter than its index of " + bytes_str(index_bytes));
    std::vector<std::byte> table = read_range(in, a.index_at_end ? size - index_bytes : 0, index_bytes);
    if (a.index_crc32c) check_crc32c(table, "the index");
    const auto u64 = [&](std::uint64_t at) {
      std::uint64_t v = 0;
      for (int b = 7; b >= 0; --b) v = (v << 8) | static_cast<std::uint64_t>(table[at + static_cast<std::uint64_t>(b)]);
      return v;
    };
    const std::uint64_t offset = u64(16 * entry), nbytes = u64(16 * entry + 8);
    bytes_read += index_bytes;
    if (offset == kNoChunk && nbytes == kNoChunk) return std::nullopt;
    if (offset > size || nbytes > size - offset)
      throw Error("its index puts chunk " + std::to_string(entry) + " at bytes " + std::to_string(offset) + " + " + std::to_string(nbytes) +
                  " of a file of " + bytes_str(size));
    std::vector<std::byte> stored = read_range(in, offset, nbytes);
    bytes_read += stored.size();
    return with_context("its chunk " + std::to_string(entry), [&] { return decode_stored(a, std::move(stored), bytes); });
  });
}

std::uint32_t crc32c(const std::byte* data, std::size_t size) {
  static const std::array<std::uint32_t, 256> table = [] {
    std::array<std::uint32_t, 256> t{};
    for (std::uint32_t i = 0; i < 256; ++i) {
      std::uint32_t c = i;
      for (int k = 0; k < 8; ++k) c = (c & 1) ? 0x82F63B78u ^ (c >> 1) : c >> 1;
      t[i] = c;
    }
    return t;
  }();
  std::uint32_t crc = 0xFFFFFFFFu;
  for (std::size_t i = 0; i < size; ++i) crc = table[(crc ^ static_cast<std::uint32_t>(data[i])) & 0xFFu] ^ (crc >> 8);
  return crc ^ 0xFFFFFFFFu;
}

}  // namespace penumbra::io_detail
