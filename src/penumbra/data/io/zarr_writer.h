// Writes a volume as an OME-Zarr 0.4 image pyramid (Zarr v2, "/" chunk keys, Blosc), what
// `penumbra convert` makes of any volume penumbra reads: napari, ome-zarr-py, python3-zarr and
// penumbra's own reader (zarr_loader.cpp) open it.
//
// The pyramid is written as a stream: slices of level 0 go in along z, in order, and each level keeps
// only one row of chunks (chunk slices of its x·y) and one slice waiting for its pair, so that a volume
// larger than memory converts in about 1.34 · chunk · x · y voxels (OmeZarrStreamWriter::buffer_bytes).
#pragma once

#include <array>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>

#include "penumbra/data/volume.h"

namespace penumbra {

struct OmeZarrWriteOptions {
  int chunk = 64;               // chunk edge in voxels (8 to 512)
  std::string codec = "lz4";    // Blosc's compressor: lz4, zstd or zlib (byte shuffle)
  int clevel = 5;               // Blosc's level, 1 to 9
  std::string unit;             // the axes' unit ("millimeter", "micrometer"; "" writes none)
  std::string name;             // the image's name in its metadata
  // Called after each slice of level 0 has gone in: (slices in, slices in all, chunk bytes written so far).
  std::function<void(std::int64_t, std::int64_t, std::uint64_t)> progress;
};

struct OmeZarrWritten {
  int levels = 0;               // level 0 is the volume; each next one halves every axis longer than 1
  std::uint64_t chunk_files = 0;
  std::uint64_t bytes = 0;      // chunk bytes written
};

// Level l+1 is the mean of level l's 2×2×2 blocks (fewer at odd edges; integers rounded half up), down
// to the first level that fits one chunk. Each level's scale and translation place its voxel centres in
// the volume's world (spacing × 2^l, origin + (2^l − 1)/2 × spacing). The folder `path` must not exist:
// the pyramid is written into a hidden sibling folder and renamed into place by finish(), so a failure
// (or a writer destroyed before finish) leaves nothing at `path`.
class OmeZarrStreamWriter {
public:
  // dims x, y, z of level 0 (each from 1; no product limit: level 0 is never held), its spacing and
  // origin (the first voxel's centre). Checks the options and the path (Error).
  OmeZarrStreamWriter(const std::string& path, ScalarType type, const std::array<std::int64_t, 3>& dims, const Vec3& spacing,
                      const Vec3& origin, const OmeZarrWriteOptions& options);
  ~OmeZarrStreamWriter();
  OmeZarrStreamWriter(const OmeZarrStreamWriter&) = delete;
  OmeZarrStreamWriter& operator=(const OmeZarrStreamWriter&) = delete;

  // `count` whole slices of level 0 (x fastest, then y, then z), the next ones along z, in the
  // writer's voxel type. Error past the last slice.
  void add_slices(const std::byte* voxels, std::int64_t count);
  std::int64_t slices_in() const;
  // Writes what the levels still hold and the metadata, and renames the pyramid into place. Error unless
  // every slice went in.
  OmeZarrWritten finish();
  int levels() const;
  // What the writer holds at most, in bytes (its rows of chunks and waiting slices).
  std::uint64_t buffer_bytes() const;

private:
  struct State;
  std::unique_ptr<State> state_;
};

// The whole of a dense `volume` through an OmeZarrStreamWriter (Error on a bricked one).
OmeZarrWritten write_ome_zarr(const Volume& volume, const std::string& path, const OmeZarrWriteOptions& options);

}  // namespace penumbra
