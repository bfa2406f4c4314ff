// Per-sphere results of the particle AO's cones, kept across frames (a sphere's cone occlusion depends
// on the sphere and the density volume alone): one byte a cone (occlusion × 255), eight to a 64-bit
// word so that a pixel reads its sphere's cones in a few loads, and a mask of the cones traced. When
// an entry for every sphere fits the byte budget, sphere i owns entry i. Otherwise
// (1M4X: 16 M spheres × 40 bytes = 650 MB) a sphere is given an entry the first time one of its cones
// is stored, from a pool the budget sizes, so that only the spheres a frame shades pay; when the pool
// is used up, further spheres are traced every time. Thread-safe: a sphere's entry is claimed by one
// thread (a compare-and-swap marks it; the others skip storing until it is set, so no entry is wasted),
// cones are published with release/acquire.
#pragma once

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>

namespace penumbra {

class SphereConeCache {
public:
  static constexpr std::size_t kMaxCones = 64;  // the mask's bits

  // Empties the cache for `spheres` spheres of `cones` cones within `max_bytes` (no cache: cones > 64,
  // or not even the sphere-to-entry table fits).
  void reset(std::size_t spheres, std::size_t cones, std::size_t max_bytes);
  // Cone `cone` of sphere `sphere` if stored (q: occlusion × 255).
  bool get(std::uint32_t sphere, std::size_t cone, std::uint8_t& q) const;
  void put(std::uint32_t sphere, std::size_t cone, std::uint8_t q) const;  // a cache behind const queries
  // Every cone of a sphere at once: returns the mask of those stored. A sphere with an entry writes
  // q[cone] for all its cones (0 where not stored; q has room for cones rounded up to a multiple of
  // 8); one without (mask 0) leaves q as it was.
  std::uint64_t get_all(std::uint32_t sphere, std::uint8_t* q) const;
  // Drops what is stored for one sphere (its entry, if it has one, stays its own). Not concurrent with
  // queries of the same sphere.
  void forget(std::uint32_t sphere);
  // True when reset(spheres, cones, max_bytes) would lay out the cache as it is now.
  bool laid_out_for(std::size_t spheres, std::size_t cones, std::size_t max_bytes) const {
    return spheres == spheres_ && cones == cones_ && max_bytes == max_bytes_;
  }

  bool enabled() const { return capacity_ > 0; }
  bool every_sphere() const { return !slot_; }  // sphere i owns entry i
  std::size_t entries_used() const;
  std::size_t memory_bytes() const;

private:
  static constexpr std::uint32_t kNoEntry = 0xFFFFFFFEu, kClaiming = 0xFFFFFFFFu;  // slot_ markers
  static constexpr std::size_t kNone = ~std::size_t{0};
  std::size_t entry_of(std::uint32_t sphere) const;  // the sphere's entry, kNone when it has none (yet)
  std::size_t entry_bytes() const { return (words_ + 1) * sizeof(std::uint64_t); }
  std::size_t spheres_ = 0, cones_ = 0, words_ = 0, capacity_ = 0, max_bytes_ = 0;  // words_: value words per entry
  std::unique_ptr<std::uint32_t[]> slot_;   // pooled: entry + 1 of each sphere (0: none yet, or a marker); null: entry = sphere
  std::unique_ptr<std::uint64_t[]> bits_;   // per entry: the cones stored
  std::unique_ptr<std::uint64_t[]> values_;  // per entry, words_ words: cone c in byte c mod 8 of word c / 8 (0 until stored)
  mutable std::atomic<std::size_t> claimed_{0};
};

}  // namespace penumbra
