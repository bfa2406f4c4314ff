// The bytes a dense volume owns, on malloc and realloc instead of a std::vector: resizing a large buffer
// (glibc maps every block over 32 MiB by itself) remaps its pages rather than copying them into a second
// buffer, so a refined box that moves into a larger box (Volume::move_voxels) never holds two copies of its
// voxels, and one that moves into a smaller box gives the pages it no longer needs back. The bytes are
// left uninitialised, as a loader that writes every voxel wants (the Volume zeroes them when asked).
#pragma once

#include <cstddef>
#include <cstdlib>
#include <cstring>
#include <new>
#include <utility>

namespace penumbra {

class VoxelBytes {
public:
  VoxelBytes() = default;
  VoxelBytes(const VoxelBytes& o) {
    resize(o.size_);
    if (size_) std::memcpy(data_, o.data_, size_);
  }
  VoxelBytes(VoxelBytes&& o) noexcept : data_(std::exchange(o.data_, nullptr)), size_(std::exchange(o.size_, 0)) {}
  VoxelBytes& operator=(VoxelBytes o) noexcept {
    std::swap(data_, o.data_);
    std::swap(size_, o.size_);
    return *this;
  }
  ~VoxelBytes() { std::free(data_); }

  // `bytes` long, the first min(bytes, size()) bytes kept (the buffer may move: data() changes).
  void resize(std::size_t bytes) {
    if (bytes == size_) return;
    if (bytes == 0) {
      std::free(std::exchange(data_, nullptr));
      size_ = 0;
      return;
    }
    void* p = std::realloc(data_, bytes);
    if (!p) throw std::bad_alloc();
    data_ = static_cast<std::byte*>(p);
    size_ = bytes;
  }
  std::byte* data() { return data_; }
  const std::byte* data() const { return data_; }
  std::size_t size() const { return size_; }
  bool empty() const { return size_ == 0; }

private:
  std::byte* data_ = nullptr;
  std::size_t size_ = 0;
};

}  // namespace penumbra
