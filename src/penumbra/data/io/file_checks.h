// Small checks shared by the volume loaders: the path must name an existing regular file (a directory,
// FIFO or device would make the libraries block or fail obscurely), and compressed data can only
// expand by a bounded factor, so a header asking for far more data than the file could hold is a lie
// we can reject before any library allocates for it.
#pragma once

#include <cstdint>
#include <filesystem>
#include <string>
#include <system_error>

#include "penumbra/core/error.h"

namespace penumbra::io_detail {

// Deflate (gzip, zlib) cannot expand data by more than about 1032:1, so a compressed stream of n bytes
// holds at most this many times n bytes (plus a little for tiny streams).
constexpr std::uint64_t kMaxDeflateRatio = 1032;

inline bool deflate_could_hold(std::uint64_t compressed_bytes, std::uint64_t needed_bytes) {
  return needed_bytes / kMaxDeflateRatio <= compressed_bytes + 1;
}

// Size in bytes of the regular file at `path`; Error when it is missing or not a regular file.
inline std::uint64_t regular_file_size(const std::string& path) {
  std::error_code ec;
  const auto status = std::filesystem::status(path, ec);
  if (status.type() == std::filesystem::file_type::not_found) throw Error("file not found");
  if (ec) throw Error("cannot access the file (" + ec.message() + ")");
  if (status.type() != std::filesystem::file_type::regular) throw Error("not a regular file");
  const std::uintmax_t size = std::filesystem::file_size(path, ec);
  if (ec) throw Error("cannot read the file size (" + ec.message() + ")");
  return static_cast<std::uint64_t>(size);
}

// Error unless `path`, with its links resolved, lies inside the folder `root` (given canonical); an empty
// root confines nothing. A file that names another (an NRRD header's data file, a slice found in a
// DICOM folder) must not reach outside the folder its reader was confined to (the viewer's data root).
inline void check_inside(const std::filesystem::path& path, const std::string& root, const std::string& what) {
  if (root.empty()) return;
  std::error_code ec;
  const std::filesystem::path resolved = std::filesystem::weakly_canonical(std::filesystem::absolute(path), ec);
  const std::filesystem::path rel = ec ? std::filesystem::path() : resolved.lexically_relative(root);
  if (rel.empty() || *rel.begin() == "..")
    throw Error(what + " " + path.string() + " lies outside the data root (files may name files only inside it)");
}

inline std::string bytes_str(std::uint64_t n) { return std::to_string(n) + " bytes"; }

}  // namespace penumbra::io_detail
