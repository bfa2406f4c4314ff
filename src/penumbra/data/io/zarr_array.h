// One Zarr array: its metadata (v2 .zarray or v3 zarr.json) and its chunks, found and decoded. The
// volume reader (zarr_loader.cpp) places the chunks' elements; this file knows the two formats.
//
// Zarr v2 (https://zarr.readthedocs.io/en/stable/spec/v2.html): a compressor (blosc, zlib, gzip, zstd or
// none), C or F order, "." or "/" separators. Zarr v3 (https://zarr-specs.readthedocs.io/en/latest/v3/core/):
// data_type, a regular chunk grid, the default ("c/0/0/0") or v2 chunk key encoding, and the codecs
// transpose (C or F order), bytes (either endian), blosc, gzip, zstd and crc32c, and sharding_indexed
// (inner chunks in one shard file with their index at its end or start; each inner chunk read alone by
// seeking). Anything else is refused by name.
#pragma once

#include <nlohmann/json.hpp>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace penumbra::io_detail {

// A metadata file (at most 1 MiB) as JSON; an Error naming it otherwise.
nlohmann::json read_zarr_json(const std::filesystem::path& file);
// Fields of metadata that may be anything: j[key] when j is an object holding it, else null; a string
// field, `fallback` when absent, an Error naming the key when it is not a string. Neither throws
// nlohmann's exceptions, whatever the file holds.
const nlohmann::json& json_field(const nlohmann::json& j, const char* key);
std::string json_string(const nlohmann::json& j, const char* key, const std::string& fallback);

// The stored element type.
struct ZarrDType {
  char kind = 'u';  // u, i, f
  int size = 1;
  bool big_endian = false;
};

struct ZarrArray {
  std::filesystem::path folder;
  int format = 2;                              // 2 or 3
  std::vector<std::int64_t> shape, chunks;     // chunks: the unit decoded (a shard's inner chunk)
  ZarrDType dtype;
  std::vector<std::string> codecs;             // bytes-to-bytes, as applied when written: blosc, zlib, gzip, zstd, crc32c
  double fill = 0;                             // fill_value as a number
  bool fortran = false;                        // F order (v2 "order", v3 a reversing transpose)
  std::string key_prefix;                      // "" (v2 keys) or "c" + separator (v3's default keys)
  char separator = '.';
  std::vector<std::int64_t> shard;             // v3 sharding_indexed: a shard file's shape; empty without
  bool index_at_end = true;                    // where a shard's index lies
  bool index_crc32c = false;                   // its index ends in a CRC32C
};

// The array in `folder` (.zarray, or zarr.json of node_type "array"); an Error naming the key otherwise.
ZarrArray read_zarr_array(const std::filesystem::path& folder);

// The decoded bytes (exactly `bytes` of them) of the chunk at `index` (one chunk index per array axis),
// or nothing when it is not stored (it holds the fill value); `bytes_read` grows by what was read.
std::optional<std::vector<std::byte>> read_zarr_chunk(const ZarrArray& a, const std::vector<std::int64_t>& index, std::size_t bytes,
                                                      std::uint64_t& bytes_read);

// CRC32C (Castagnoli), as Zarr v3's crc32c codec appends it.
std::uint32_t crc32c(const std::byte* data, std::size_t size);

}  // namespace penumbra::io_detail
