#include "penumbra/data/io/zarr_writer.h"

#include <blosc.h>

#include <nlohmann/json.hpp>

#include <atomic>
#include <cmath>
#include <cstring>
#include <fstream>
#include <mutex>
#include <optional>
#include <random>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"

namespace penumbra {

// What OmeZarrStreamWriter::State keeps (named, not anonymous: a member of an external class).
namespace ome_zarr_stream {

// One level of the pyramid as it streams: where it lies, the row of chunks being filled (up to `chunk`
// slices of its x·y) and the slice waiting for its pair before the next level gets their mean.
struct StreamLevel {
  std::array<std::int64_t, 3> dims{};  // x, y, z
  std::array<double, 3> scale{}, translation{};
  std::array<int, 3> factor{};         // to the next level: 2 along the axes longer than 1
  std::filesystem::path folder;
  std::vector<std::byte> row;          // chunk slices, x fastest
  std::int64_t row_slices = 0, row_index = 0;
  std::vector<std::byte> waiting;      // one slice
  bool has_waiting = false;
  std::vector<std::byte> mean;         // one slice of the next level, passed down
  std::int64_t slice_bytes(std::size_t voxel) const { return dims[0] * dims[1] * static_cast<std::int64_t>(voxel); }
};

}  // namespace ome_zarr_stream

namespace {

using ome_zarr_stream::StreamLevel;

namespace fs = std::filesystem;

const char* zarr_dtype(ScalarType t) {
  switch (t) {
    case ScalarType::UInt8: return "|u1";
    case ScalarType::Int16: return "<i2";
    case ScalarType::UInt16: return "<u2";
    case ScalarType::Float32: return "<f4";
  }
  return "<f4";
}

void write_text(const fs::path& file, const std::string& text) {
  std::ofstream out(file, std::ios::binary);
  if (!out || !out.write(text.data(), static_cast<std::streamsize>(text.size())))
    throw Error("cannot write " + file.string());
}


// The means of one or two slices' 2×2 blocks (the 2×2×2 blocks of the level; fewer at odd edges).
template <class T>
void downsample_slices(const StreamLevel& in, const T* a, const T* b, const StreamLevel& out, T* result) {
  const std::int64_t fx = in.factor[0], fy = in.factor[1];
  parallel_for(static_cast<std::size_t>(out.dims[1]), [&](std::size_t y0, std::size_t y1) {
    for (auto y = static_cast<std::int64_t>(y0); y < static_cast<std::int64_t>(y1); ++y)
      for (std::int64_t x = 0; x < out.dims[0]; ++x) {
        double sum = 0;
        int count = 0;
        for (const T* slice : {a, b}) {
          if (!slice) continue;
          for (std::int64_t j = y * fy; j < std::min(in.dims[1], (y + 1) * fy); ++j)
            for (std::int64_t i = x * fx; i < std::min(in.dims[0], (x + 1) * fx); ++i, ++count)
              sum += static_cast<double>(slice[j * in.dims[0] + i]);
        }
        const double mean = sum / count;
        T& v = result[y * out.dims[0] + x];
        if constexpr (std::is_floating_point_v<T>) v = static_cast<T>(mean);
        else v = static_cast<T>(std::floor(mean + 0.5));
      }
  });
}

}  // namespace

struct OmeZarrStreamWriter::State {
  ScalarType type;
  std::size_t voxel;
  OmeZarrWriteOptions options;
  fs::path target, partial;
  std::vector<StreamLevel> levels;
  std::int64_t slices_in = 0;
  std::atomic<std::uint64_t> files{0}, bytes{0};
  bool finished = false;

  // Writes the level's row of chunks (its slices so far; the rest of the chunks is the fill value).
  template <class T>
  void write_row(StreamLevel& level) {
    const std::int64_t c = options.chunk;
    const std::array<std::int64_t, 2> grid{(level.dims[0] + c - 1) / c, (level.dims[1] + c - 1) / c};
    const std::size_t n = static_cast<std::size_t>(grid[0] * grid[1]);
    const std::size_t raw_bytes = static_cast<std::size_t>(c * c * c) * sizeof(T);
    const T* rows = reinterpret_cast<const T*>(level.row.data());
    std::mutex failure_mutex;
    std::optional<std::string> failure;
    const fs::path row_folder = level.folder / std::to_string(level.row_index);
    parallel_for(n, [&](std::size_t b0, std::size_t b1) {
      std::vector<T> chunk(static_cast<std::size_t>(c * c * c));
      std::vector<std::byte> packed(raw_bytes + BLOSC_MAX_OVERHEAD);
      for (std::size_t b = b0; b < b1; ++b) {
        const std::int64_t cx = static_cast<std::int64_t>(b) % grid[0], cy = static_cast<std::int64_t>(b) / grid[0];
        const std::int64_t x_count = std::min(c, level.dims[0] - cx * c);
        if (x_count < c || (cy + 1) * c > level.dims[1] || level.row_slices < c)
          std::fill(chunk.begin(), chunk.end(), T{});  // beyond the array's edge: the fill value
        for (std::int64_t z = 0; z < level.row_slices; ++z)
          for (std::int64_t y = 0; y < c && cy * c + y < level.dims[1]; ++y)
            std::memcpy(chunk.data() + (z * c + y) * c, rows + (z * level.dims[1] + cy * c + y) * level.dims[0] + cx * c,
                        static_cast<std::size_t>(x_count) * sizeof(T));
        const int size = blosc_compress_ctx(options.clevel, BLOSC_SHUFFLE, sizeof(T), raw_bytes, chunk.data(), packed.data(),
                                            packed.size(), options.codec.c_str(), 0, 1);
        try {
          if (size <= 0) throw Error("Blosc could not compress a chunk with " + options.codec);
          const fs::path dir = row_folder / std::to_string(cy);
          fs::create_directories(dir);
          const fs::path file = dir / std::to_string(cx);
          std::ofstream out(file, std::ios::binary);
          if (!out || !out.write(reinterpret_cast<const char*>(packed.data()), size)) throw Error("cannot write " + file.string());
          files += 1;
          bytes += static_cast<std::uint64_t>(size);
        } catch (const std::exception& e) {
          const std::lock_guard lock(failure_mutex);
          if (!failure) failure = e.what();
        }
      }
    });
    if (failure) throw Error(*failure);
    level.row_slices = 0;
    ++level.row_index;
  }

  // One slice into level l: onto its row of chunks, and paired into level l + 1.
  template <class T>
  void add_slice(std::size_t l, const T* slice) {
    StreamLevel& level = levels[l];
    const std::int64_t n = level.dims[0] * level.dims[1];
    std::memcpy(level.row.data() + static_cast<std::size_t>(level.row_slices * n) * sizeof(T), slice,
                static_cast<std::size_t>(n) * sizeof(T));
    if (++level.row_slices == options.chunk) write_row<T>(level);
    if (l + 1 == levels.size()) return;
    if (level.factor[2] == 2 && !level.has_waiting) {
      std::memcpy(level.waiting.data(), slice, static_cast<std::size_t>(n) * sizeof(T));
      level.has_waiting = true;
      return;
    }
    pass_down<T>(l, level.has_waiting ? reinterpret_cast<const T*>(level.waiting.data()) : slice,
                 level.has_waiting ? slice : nullptr);
  }

  template <class T>
  void pass_down(std::size_t l, const T* a, const T* b) {
    StreamLevel& level = levels[l];
    const StreamLevel& next = levels[l + 1];
    T* mean = reinterpret_cast<T*>(level.mean.data());
    downsample_slices(level, a, b, next, mean);
    level.has_waiting = false;
    add_slice<T>(l + 1, mean);
  }
};

OmeZarrStreamWriter::OmeZarrStreamWriter(const std::string& path, ScalarType type, const std::array<std::int64_t, 3>& dims,
                                         const Vec3& spacing, const Vec3& origin, const OmeZarrWriteOptions& o)
    : state_(std::make_unique<State>()) {
  if (o.chunk < 8 || o.chunk > 512) throw Error("chunk " + std::to_string(o.chunk) + " (expected 8 to 512 voxels)");
  if (o.codec != "lz4" && o.codec != "zstd" && o.codec != "zlib") throw Error("codec '" + o.codec + "' (expected lz4, zstd or zlib)");
  if (o.clevel < 1 || o.clevel > 9) throw Error("compression level " + std::to_string(o.clevel) + " (expected 1 to 9)");
  for (int a = 0; a < 3; ++a)
    if (dims[a] < 1 || dims[a] > (std::int64_t{1} << 24))
      throw Error("dimension " + std::to_string(dims[a]) + " (expected 1 to 2^24 voxels along each axis)");
  State& s = *state_;
  s.type = type;
  s.voxel = scalar_size(type);
  s.options = o;
  s.target = fs::absolute(path).lexically_normal();
  std::error_code ec;
  if (fs::exists(s.target, ec)) throw Error(s.target.string() + ": already exists (convert writes a new folder)");
  if (!fs::is_directory(s.target.parent_path(), ec)) throw Error(s.target.parent_path().string() + ": no such folder");
  std::random_device random;
  s.partial = s.target.parent_path() / ("." + s.target.filename().string() + ".partial-" + std::to_string(random()));
  StreamLevel level;
  level.dims = dims;
  for (int a = 0; a < 3; ++a) {
    level.scale[a] = spacing[a];
    level.translation[a] = origin[a];
  }
  while (true) {
    const bool last = std::max({level.dims[0], level.dims[1], level.dims[2]}) <= o.chunk;
    StreamLevel next;
    for (int a = 0; a < 3; ++a) {
      level.factor[a] = level.dims[a] > 1 ? 2 : 1;
      next.dims[a] = (level.dims[a] + level.factor[a] - 1) / level.factor[a];
      next.scale[a] = level.scale[a] * level.factor[a];
      next.translation[a] = level.translation[a] + (level.factor[a] - 1) * 0.5 * level.scale[a];
    }
    level.folder = s.partial / std::to_string(s.levels.size());
    s.levels.push_back(std::move(level));
    if (last) break;
    level = std::move(next);
  }
  try {
    fs::create_directories(s.partial);
    write_text(s.partial / ".zgroup", "{\n  \"zarr_format\": 2\n}");
    const std::int64_t c = o.chunk;
    for (StreamLevel& l : s.levels) {
      fs::create_directories(l.folder);
      const nlohmann::json meta = {{"zarr_format", 2},
                                   {"shape", {l.dims[2], l.dims[1], l.dims[0]}},
                                   {"chunks", {c, c, c}},
                                   {"dtype", zarr_dtype(type)},
                                   {"compressor", {{"id", "blosc"}, {"cname", o.codec}, {"clevel", o.clevel}, {"shuffle", 1}, {"blocksize", 0}}},
                                   {"fill_value", 0},
                                   {"order", "C"},
                                   {"filters", nullptr},
                                   {"dimension_separator", "/"}};
      write_text(l.folder / ".zarray", meta.dump(2));
      l.row.resize(static_cast<std::size_t>(l.slice_bytes(s.voxel) * c));
      l.waiting.resize(static_cast<std::size_t>(l.slice_bytes(s.voxel)));
    }
    for (std::size_t l = 0; l + 1 < s.levels.size(); ++l) s.levels[l].mean.resize(static_cast<std::size_t>(s.levels[l + 1].slice_bytes(s.voxel)));
  } catch (...) {
    fs::remove_all(s.partial, ec);
    throw;
  }
}

OmeZarrStreamWriter::~OmeZarrStreamWriter() {
  if (!state_->finished) {
    std::error_code ec;
    fs::remove_all(state_->partial, ec);
  }
}

int OmeZarrStreamWriter::levels() const { return static_cast<int>(state_->levels.size()); }
std::int64_t OmeZarrStreamWriter::slices_in() const { return state_->slices_in; }

std::uint64_t OmeZarrStreamWriter::buffer_bytes() const {
  std::uint64_t total = 0;
  for (const StreamLevel& l : state_->levels) total += l.row.size() + l.waiting.size() + l.mean.size();
  return total;
}

void OmeZarrStreamWriter::add_slices(const std::byte* voxels, std::int64_t count) {
  State& s = *state_;
  if (s.finished) throw Error("the OME-Zarr pyramid is finished");
  const StreamLevel& top = s.levels.front();
  if (count < 0 || s.slices_in + count > top.dims[2])
    throw Error("slices " + std::to_string(s.slices_in) + " + " + std::to_string(count) + " (the volume has " +
                std::to_string(top.dims[2]) + ")");
  const std::int64_t slice_bytes = top.slice_bytes(s.voxel);
  with_scalar_type(s.type, [&](auto t) {
    using T = decltype(t);
    for (std::int64_t k = 0; k < count; ++k) {
      s.add_slice<T>(0, reinterpret_cast<const T*>(voxels + k * slice_bytes));
      ++s.slices_in;
      if (s.options.progress) s.options.progress(s.slices_in, top.dims[2], s.bytes.load());
    }
  });
}

OmeZarrWritten OmeZarrStreamWriter::finish() {
  State& s = *state_;
  if (s.finished) throw Error("the OME-Zarr pyramid is finished");
  if (s.slices_in != s.levels.front().dims[2])
    throw Error("the pyramid got " + std::to_string(s.slices_in) + " of its " + std::to_string(s.levels.front().dims[2]) + " slices");
  nlohmann::json datasets = nlohmann::json::array();
  with_scalar_type(s.type, [&](auto t) {
    using T = decltype(t);
    for (std::size_t l = 0; l < s.levels.size(); ++l) {
      StreamLevel& level = s.levels[l];
      if (level.has_waiting) s.pass_down<T>(l, reinterpret_cast<const T*>(level.waiting.data()), nullptr);  // an odd last slice
      if (level.row_slices > 0) s.write_row<T>(level);
      level.row = {};
      level.waiting = {};
      level.mean = {};
      datasets.push_back({{"path", std::to_string(l)},
                          {"coordinateTransformations",
                           {{{"type", "scale"}, {"scale", {level.scale[2], level.scale[1], level.scale[0]}}},
                            {{"type", "translation"}, {"translation", {level.translation[2], level.translation[1], level.translation[0]}}}}}});
    }
  });
  nlohmann::json axes = nlohmann::json::array();
  for (const char* name : {"z", "y", "x"}) {
    nlohmann::json axis = {{"name", name}, {"type", "space"}};
    if (!s.options.unit.empty()) axis["unit"] = s.options.unit;
    axes.push_back(axis);
  }
  const nlohmann::json attrs = {{"multiscales",
                                 {{{"version", "0.4"},
                                   {"name", s.options.name},
                                   {"axes", axes},
                                   {"datasets", datasets},
                                   {"type", "mean"},
                                   {"metadata", {{"description", "2x2x2 block means (penumbra convert)"}}}}}}};
  write_text(s.partial / ".zattrs", attrs.dump(2));
  fs::rename(s.partial, s.target);
  s.finished = true;
  return {static_cast<int>(s.levels.size()), s.files.load(), s.bytes.load()};
}

OmeZarrWritten write_ome_zarr(const Volume& volume, const std::string& path, const OmeZarrWriteOptions& options) {
  if (volume.is_bricked()) throw Error("a sparse (bricked) volume cannot be written as OME-Zarr yet");
  const auto& d = volume.dims();
  OmeZarrStreamWriter writer(path, volume.type(), {d[0], d[1], d[2]}, volume.spacing(), volume.origin(), options);
  writer.add_slices(volume.data(), d[2]);
  return writer.finish();
}

}  // namespace penumbra
