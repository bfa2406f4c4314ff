#include "penumbra/data/io/zarr_writer.h"

#include <blosc.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include <atomic>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <optional>
#include <random>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"

namespace penumbra {

namespace {

namespace fs = std::filesystem;

// One level of the pyramid: its voxels (x fastest; level 0 points at the volume's own, the others own
// theirs) and where it lies.
template <class T>
struct LevelVoxels {
  std::array<std::int64_t, 3> dims{};  // x, y, z
  std::array<double, 3> scale{}, translation{};
  std::vector<T> owned;
  const T* voxels = nullptr;
};

// The mean of the level's 2×2×2 blocks along the axes longer than 1 (integers rounded half up).
template <class T>
LevelVoxels<T> downsampled(const LevelVoxels<T>& in) {
  LevelVoxels<T> out;
  std::array<int, 3> factor{};
  for (int a = 0; a < 3; ++a) {
    factor[a] = in.dims[a] > 1 ? 2 : 1;
    out.dims[a] = (in.dims[a] + factor[a] - 1) / factor[a];
    out.scale[a] = in.scale[a] * factor[a];
    out.translation[a] = in.translation[a] + (factor[a] - 1) * 0.5 * in.scale[a];
  }
  out.owned.resize(static_cast<std::size_t>(out.dims[0] * out.dims[1] * out.dims[2]));
  out.voxels = out.owned.data();
  parallel_for(static_cast<std::size_t>(out.dims[2]), [&](std::size_t z0, std::size_t z1) {
    for (auto z = static_cast<std::int64_t>(z0); z < static_cast<std::int64_t>(z1); ++z)
      for (std::int64_t y = 0; y < out.dims[1]; ++y)
        for (std::int64_t x = 0; x < out.dims[0]; ++x) {
          double sum = 0;
          int count = 0;
          for (std::int64_t k = z * factor[2]; k < std::min(in.dims[2], (z + 1) * factor[2]); ++k)
            for (std::int64_t j = y * factor[1]; j < std::min(in.dims[1], (y + 1) * factor[1]); ++j)
              for (std::int64_t i = x * factor[0]; i < std::min(in.dims[0], (x + 1) * factor[0]); ++i, ++count)
                sum += static_cast<double>(in.voxels[static_cast<std::size_t>((k * in.dims[1] + j) * in.dims[0] + i)]);
          const double mean = sum / count;
          T& v = out.owned[static_cast<std::size_t>((z * out.dims[1] + y) * out.dims[0] + x)];
          if constexpr (std::is_floating_point_v<T>) v = static_cast<T>(mean);
          else v = static_cast<T>(std::floor(mean + 0.5));
        }
  });
  return out;
}

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

struct Counters {
  std::atomic<std::uint64_t> files{0}, bytes{0};
};

// Writes one level's array: .zarray and its chunks ("z/y/x" keys), each compressed by Blosc.
template <class T>
void write_level(const LevelVoxels<T>& level, ScalarType type, const fs::path& folder, const OmeZarrWriteOptions& o, int index, int levels,
                 Counters& counters) {
  fs::create_directories(folder);
  const std::int64_t c = o.chunk;
  const nlohmann::json meta = {{"zarr_format", 2},
                               {"shape", {level.dims[2], level.dims[1], level.dims[0]}},
                               {"chunks", {c, c, c}},
                               {"dtype", zarr_dtype(type)},
                               {"compressor", {{"id", "blosc"}, {"cname", o.codec}, {"clevel", o.clevel}, {"shuffle", 1}, {"blocksize", 0}}},
                               {"fill_value", 0},
                               {"order", "C"},
                               {"filters", nullptr},
                               {"dimension_separator", "/"}};
  write_text(folder / ".zarray", meta.dump(2));
  const std::array<std::int64_t, 3> grid{(level.dims[0] + c - 1) / c, (level.dims[1] + c - 1) / c, (level.dims[2] + c - 1) / c};
  const std::size_t n = static_cast<std::size_t>(grid[0] * grid[1] * grid[2]);
  const std::size_t raw_bytes = static_cast<std::size_t>(c * c * c) * sizeof(T);
  std::atomic<std::size_t> done{0};
  std::mutex progress_mutex, failure_mutex;
  std::optional<std::string> failure;
  parallel_for(n, [&](std::size_t b0, std::size_t b1) {
    std::vector<T> chunk(static_cast<std::size_t>(c * c * c));
    std::vector<std::byte> packed(raw_bytes + BLOSC_MAX_OVERHEAD);
    for (std::size_t b = b0; b < b1; ++b) {
      const std::int64_t cx = static_cast<std::int64_t>(b) % grid[0], cy = static_cast<std::int64_t>(b) / grid[0] % grid[1],
                         cz = static_cast<std::int64_t>(b) / (grid[0] * grid[1]);
      std::fill(chunk.begin(), chunk.end(), T{});  // beyond the array's edge: the fill value
      for (std::int64_t z = 0; z < c && cz * c + z < level.dims[2]; ++z)
        for (std::int64_t y = 0; y < c && cy * c + y < level.dims[1]; ++y) {
          const std::int64_t x_count = std::min(c, level.dims[0] - cx * c);
          std::memcpy(chunk.data() + (z * c + y) * c,
                      level.voxels + ((cz * c + z) * level.dims[1] + cy * c + y) * level.dims[0] + cx * c,
                      static_cast<std::size_t>(x_count) * sizeof(T));
        }
      const int size = blosc_compress_ctx(o.clevel, BLOSC_SHUFFLE, sizeof(T), raw_bytes, chunk.data(), packed.data(), packed.size(),
                                          o.codec.c_str(), 0, 1);
      try {
        if (size <= 0) throw Error("Blosc could not compress a chunk with " + o.codec);
        const fs::path dir = folder / std::to_string(cz) / std::to_string(cy);
        fs::create_directories(dir);
        const fs::path file = dir / std::to_string(cx);
        std::ofstream out(file, std::ios::binary);
        if (!out || !out.write(reinterpret_cast<const char*>(packed.data()), size)) throw Error("cannot write " + file.string());
        counters.files += 1;
        counters.bytes += static_cast<std::uint64_t>(size);
      } catch (const std::exception& e) {
        const std::lock_guard lock(failure_mutex);
        if (!failure) failure = e.what();
      }
      const std::size_t written = ++done;
      if (o.progress) {
        const std::lock_guard lock(progress_mutex);
        o.progress(index, levels, written, n);
      }
    }
  });
  if (failure) throw Error(*failure);
}

int level_count(std::array<std::int64_t, 3> dims, int chunk) {
  int levels = 1;
  while (std::max({dims[0], dims[1], dims[2]}) > chunk) {
    for (auto& d : dims) d = d > 1 ? (d + 1) / 2 : 1;
    ++levels;
  }
  return levels;
}

}  // namespace

OmeZarrWritten write_ome_zarr(const Volume& volume, const std::string& path, const OmeZarrWriteOptions& o) {
  if (volume.is_bricked()) throw Error("a sparse (bricked) volume cannot be written as OME-Zarr yet");
  if (o.chunk < 8 || o.chunk > 512) throw Error("chunk " + std::to_string(o.chunk) + " (expected 8 to 512 voxels)");
  if (o.codec != "lz4" && o.codec != "zstd" && o.codec != "zlib") throw Error("codec '" + o.codec + "' (expected lz4, zstd or zlib)");
  if (o.clevel < 1 || o.clevel > 9) throw Error("compression level " + std::to_string(o.clevel) + " (expected 1 to 9)");
  const fs::path target = fs::absolute(path).lexically_normal();
  std::error_code ec;
  if (fs::exists(target, ec)) throw Error(target.string() + ": already exists (convert writes a new folder)");
  if (!fs::is_directory(target.parent_path(), ec)) throw Error(target.parent_path().string() + ": no such folder");
  std::random_device random;
  const fs::path partial = target.parent_path() / ("." + target.filename().string() + ".partial-" + std::to_string(random()));
  OmeZarrWritten written;
  try {
    fs::create_directories(partial);
    write_text(partial / ".zgroup", "{\n  \"zarr_format\": 2\n}");
    Counters counters;
    nlohmann::json datasets = nlohmann::json::array();
    volume.with_voxel_type([&](auto t) {
      using T = decltype(t);
      LevelVoxels<T> level;
      for (int a = 0; a < 3; ++a) {
        level.dims[a] = volume.dims()[a];
        level.scale[a] = volume.spacing()[a];
        level.translation[a] = volume.origin()[a];
      }
      level.voxels = volume.data_as<T>();  // level 0 is written from the volume itself, not a copy
      const int levels = level_count(level.dims, o.chunk);
      for (int l = 0; l < levels; ++l) {
        if (l > 0) level = downsampled(level);
        write_level(level, volume.type(), partial / std::to_string(l), o, l, levels, counters);
        datasets.push_back({{"path", std::to_string(l)},
                            {"coordinateTransformations",
                             {{{"type", "scale"}, {"scale", {level.scale[2], level.scale[1], level.scale[0]}}},
                              {{"type", "translation"}, {"translation", {level.translation[2], level.translation[1], level.translation[0]}}}}}});
      }
      written.levels = levels;
    });
    nlohmann::json axes = nlohmann::json::array();
    for (const char* name : {"z", "y", "x"}) {
      nlohmann::json axis = {{"name", name}, {"type", "space"}};
      if (!o.unit.empty()) axis["unit"] = o.unit;
      axes.push_back(axis);
    }
    const nlohmann::json attrs = {{"multiscales",
                                   {{{"version", "0.4"},
                                     {"name", o.name},
                                     {"axes", axes},
                                     {"datasets", datasets},
                                     {"type", "mean"},
                                     {"metadata", {{"description", "2x2x2 block means (penumbra convert)"}}}}}}};
    write_text(partial / ".zattrs", attrs.dump(2));
    written.chunk_files = counters.files;
    written.bytes = counters.bytes;
    fs::rename(partial, target);
  } catch (...) {
    fs::remove_all(partial, ec);
    throw;
  }
  return written;
}

}  // namespace penumbra
