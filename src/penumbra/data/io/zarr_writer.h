// Writes a volume as an OME-Zarr 0.4 image pyramid (Zarr v2, "/" chunk keys, Blosc), what
// `penumbra convert` makes of any volume penumbra reads: napari, ome-zarr-py, python3-zarr and
// penumbra's own reader (zarr_loader.cpp) open it.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include "penumbra/data/volume.h"

namespace penumbra {

struct OmeZarrWriteOptions {
  int chunk = 64;               // chunk edge in voxels (8 to 512)
  std::string codec = "lz4";    // Blosc's compressor: lz4, zstd or zlib (byte shuffle)
  int clevel = 5;               // Blosc's level, 1 to 9
  std::string unit;             // the axes' unit ("millimeter", "micrometer"; "" writes none)
  std::string name;             // the image's name in its metadata
  // Called as chunks are written: (level, levels, chunks written of the level, chunks of the level).
  std::function<void(int, int, std::size_t, std::size_t)> progress;
};

struct OmeZarrWritten {
  int levels = 0;               // level 0 is the volume; each next one halves every axis longer than 1
  std::uint64_t chunk_files = 0;
  std::uint64_t bytes = 0;      // chunk bytes written
};

// Writes `volume` (dense) into the folder `path`, which must not exist: the pyramid is written into a
// sibling folder and renamed into place once whole, so a failure leaves nothing at `path`. Level l+1 is
// the mean of level l's 2×2×2 blocks (fewer at odd edges; integers rounded half up), down to the first
// level that fits one chunk. Each level's scale and translation place its voxel centres in the volume's
// world (spacing × 2^l, origin + (2^l − 1)/2 × spacing).
OmeZarrWritten write_ome_zarr(const Volume& volume, const std::string& path, const OmeZarrWriteOptions& options);

}  // namespace penumbra
