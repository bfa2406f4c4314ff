// A gzip stream decompressed straight into the caller's memory, and checked. teem's gzip reader leaks
// its stream state (about 50 KB) on every truncated or corrupt stream, as it returns without closing
// it, and never checks the gzip checksum (it stops once it has the bytes it wants). So the stream is
// read here to the end of the gzip member that completes the data, end marker and checksum included.
// Several members are allowed, as in gzip; whatever follows the completing one is ignored, as teem does.
#pragma once

#include <zlib.h>

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <cstdio>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/data/io/file_checks.h"

namespace penumbra::io_detail {

class GzipStream {
public:
  // Reads from `in` at its position; `what` names the data in messages ("NRRD gzip data"); `want` is
  // the number of bytes the data needs and `need` says so in words ("sizes 8x8x16 ... need 1024 bytes").
  GzipStream(std::FILE* in, std::string what, std::uint64_t want, std::string need)
      : in_(in), what_(std::move(what)), need_(std::move(need)), want_(want) {
    if (inflateInit2(&zs_, 15 + 16) != Z_OK) throw Error("zlib could not start decompressing");
  }
  ~GzipStream() { inflateEnd(&zs_); }
  GzipStream(const GzipStream&) = delete;
  GzipStream& operator=(const GzipStream&) = delete;

  // Decompresses the next n bytes into out, or discards them where out is null.
  void read(std::byte* out, std::uint64_t n) {
    while (n > 0) {
      auto* dst = out ? reinterpret_cast<unsigned char*>(out) : scratch_.data();
      const std::uint64_t room = out ? std::min<std::uint64_t>(n, 1u << 30) : std::min<std::uint64_t>(n, scratch_.size());
      const std::size_t got = step(dst, static_cast<std::size_t>(room));
      if (got == 0 && exhausted_)
        throw Error(what_ + " decompresses to only " + bytes_str(total_) + " but " + need_ + " (truncated data or lying sizes)");
      n -= got;
      if (out) out += got;
    }
  }

  // After the data: reads on to the end of the member that completed it, through its checksum.
  void finish() {
    while (!member_end_) {
      step(scratch_.data(), scratch_.size());
      if (exhausted_) throw Error(what_ + " is truncated: the stream ends without its end marker and checksum");
    }
  }

private:
  // One inflate call into out[0, n): refills the input when it is used up, starts over at the end of a
  // member that leaves data to come, and notes when the input is exhausted. Returns the bytes written.
  std::size_t step(unsigned char* out, std::size_t n) {
    if (zs_.avail_in == 0 && !eof_) {
      const std::size_t got = std::fread(input_.data(), 1, input_.size(), in_);
      eof_ = got == 0;
      zs_.next_in = input_.data();
      zs_.avail_in = static_cast<uInt>(got);
    }
    zs_.next_out = out;
    zs_.avail_out = static_cast<uInt>(n);
    const int rc = inflate(&zs_, Z_NO_FLUSH);
    const std::size_t got = n - zs_.avail_out;
    total_ += got;
    member_end_ = rc == Z_STREAM_END;
    if (member_end_) {
      if (total_ < want_) inflateReset(&zs_);  // another gzip member may hold the rest
    } else if (rc == Z_BUF_ERROR) {
      exhausted_ = eof_ && zs_.avail_in == 0;  // no progress possible: the input has ended
    } else if (rc != Z_OK) {
      throw Error(what_ + " is corrupt after " + bytes_str(total_) + " (zlib: " + (zs_.msg ? zs_.msg : "error") + ")");
    }
    return got;
  }

  std::FILE* in_;
  std::string what_, need_;
  std::uint64_t want_, total_ = 0;
  z_stream zs_{};
  std::vector<unsigned char> input_ = std::vector<unsigned char>(1u << 16), scratch_ = std::vector<unsigned char>(1u << 16);
  bool eof_ = false, exhausted_ = false, member_end_ = false;
};

}  // namespace penumbra::io_detail
