// A decompressing stream parked where a reader's window of slices ended, for the next window of the same
// file to continue from. `penumbra convert` and a read reduced under a memory budget go through a file a
// window at a time, in order; without this, every window of gzip data (NIfTI .nii.gz, NRRD gzip
// encoding) decompressed everything before it again, which made a pass quadratic in its windows (a
// 200 MiB .nii.gz: 14 s, against 1.6 s continued).
//
// Streams are parked only while a pass is open (WindowPass, volume_io.h) and dropped when it ends: a
// file's size and modification time (whose clock ticks in milliseconds) cannot tell a file rewritten
// in place with as many bytes, so a stream is never resumed across separate reads. One stream is parked
// per reader, for one file (its size and modification time, and a key naming how the stream was
// opened: a detached NRRD header and its data file).
#pragma once

#include <cstdint>
#include <filesystem>
#include <functional>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace penumbra::io_detail {

// The open passes and what drops the parked streams when the last one ends (window_pass.cpp).
bool window_pass_open();
void on_window_pass_end(std::function<void()> drop);

template <class Stream>
class ParkedStream {
public:
  ParkedStream() {
    on_window_pass_end([this] {
      std::lock_guard lock(mutex_);
      stream_.reset();
    });
  }
  ParkedStream(const ParkedStream&) = delete;
  ParkedStream& operator=(const ParkedStream&) = delete;

  // The stream parked under `key` for `file` when a pass is open and it stands at or before uncompressed
  // `offset`; `at` is where it stands. Nothing when none is, or the file changed since.
  std::optional<Stream> resume(const std::string& key, const std::string& file, std::uint64_t offset, std::uint64_t& at) {
    if (!window_pass_open()) return std::nullopt;
    const auto id = identity(file);
    std::lock_guard lock(mutex_);
    if (!stream_ || !id || key_ != key || id_ != *id || at_ > offset) return std::nullopt;
    at = at_;
    std::optional<Stream> out = std::move(stream_);
    stream_.reset();
    return out;
  }
  // Parks `stream` of `file`, standing at uncompressed offset `at`, under `key`, in place of any other
  // (while a pass is open; else it is closed).
  void park(const std::string& key, const std::string& file, Stream stream, std::uint64_t at) {
    if (!window_pass_open()) return;
    const auto id = identity(file);
    std::lock_guard lock(mutex_);
    stream_.reset();
    if (!id) return;
    key_ = key, id_ = *id, at_ = at;
    stream_.emplace(std::move(stream));
  }

private:
  using Identity = std::pair<std::uintmax_t, std::filesystem::file_time_type>;  // size, modification time
  static std::optional<Identity> identity(const std::string& path) {
    std::error_code ec, ec2;
    const auto size = std::filesystem::file_size(path, ec);
    const auto modified = std::filesystem::last_write_time(path, ec2);
    if (ec || ec2) return std::nullopt;
    return Identity{size, modified};
  }

  std::mutex mutex_;
  std::string key_;
  Identity id_{};
  std::uint64_t at_ = 0;
  std::optional<Stream> stream_;
};

}  // namespace penumbra::io_detail
