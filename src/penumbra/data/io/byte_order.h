// Byte order of voxels read from files: the raw and NRRD loaders turn a file's other-endian voxels into
// this machine's order in place.
#pragma once

#include <algorithm>
#include <cstddef>

namespace penumbra::io_detail {

template <std::size_t N>
void swap_each(std::byte* data, std::size_t count) {
  for (std::size_t i = 0; i < count; ++i) std::reverse(data + i * N, data + (i + 1) * N);
}

// Reverses the bytes of each of `count` voxels of `size` bytes (1-byte voxels are left as they are).
inline void swap_bytes(std::byte* data, std::size_t count, std::size_t size) {
  switch (size) {
    case 2: swap_each<2>(data, count); break;
    case 4: swap_each<4>(data, count); break;
    case 8: swap_each<8>(data, count); break;
    default: break;
  }
}

}  // namespace penumbra::io_detail
