#include "penumbra/particles/sphere_cone_cache.h"

#include <algorithm>

namespace penumbra {

void SphereConeCache::reset(std::size_t spheres, std::size_t cones, std::size_t max_bytes) {
  spheres_ = spheres;
  cones_ = cones;
  max_bytes_ = max_bytes;
  words_ = (cones + 7) / 8;
  capacity_ = 0;
  slot_.reset();
  bits_.reset();
  values_.reset();
  claimed_.store(0, std::memory_order_relaxed);
  if (spheres == 0 || cones == 0 || cones > kMaxCones) return;
  if (spheres * entry_bytes() <= max_bytes) {  // every sphere its own entry
    capacity_ = spheres;
    bits_.reset(new std::uint64_t[spheres]());
    values_.reset(new std::uint64_t[spheres * words_]());
    return;
  }
  const std::size_t table = spheres * sizeof(std::uint32_t);
  if (table >= max_bytes) return;
  capacity_ = std::min(spheres, (max_bytes - table) / entry_bytes());
  if (capacity_ == 0) return;
  slot_.reset(new std::uint32_t[spheres]());
  bits_.reset(new std::uint64_t[capacity_]);  // an entry's mask and values are cleared when it is claimed
  values_.reset(new std::uint64_t[capacity_ * words_]);
}

std::size_t SphereConeCache::entry_of(std::uint32_t sphere) const {
  if (!enabled()) return kNone;
  if (!slot_) return sphere;
  const std::uint32_t s = std::atomic_ref<std::uint32_t>(slot_[sphere]).load(std::memory_order_acquire);
  return s == 0 || s >= kNoEntry ? kNone : s - 1;
}

bool SphereConeCache::get(std::uint32_t sphere, std::size_t cone, std::uint8_t& q) const {
  const std::size_t entry = entry_of(sphere);
  if (entry == kNone || !(std::atomic_ref<std::uint64_t>(bits_[entry]).load(std::memory_order_acquire) & (std::uint64_t{1} << cone)))
    return false;
  const std::uint64_t word = std::atomic_ref<std::uint64_t>(values_[entry * words_ + cone / 8]).load(std::memory_order_relaxed);
  q = static_cast<std::uint8_t>(word >> (8 * (cone % 8)));
  return true;
}

std::uint64_t SphereConeCache::get_all(std::uint32_t sphere, std::uint8_t* q) const {
  const std::size_t entry = entry_of(sphere);
  if (entry == kNone) return 0;
  const std::uint64_t stored = std::atomic_ref<std::uint64_t>(bits_[entry]).load(std::memory_order_acquire);
  for (std::size_t w = 0; w < words_; ++w) {
    const std::uint64_t word = std::atomic_ref<std::uint64_t>(values_[entry * words_ + w]).load(std::memory_order_relaxed);
    for (std::size_t b = 0; b < 8; ++b) q[8 * w + b] = static_cast<std::uint8_t>(word >> (8 * b));
  }
  return stored;
}

void SphereConeCache::forget(std::uint32_t sphere) {
  const std::size_t entry = entry_of(sphere);
  if (entry == kNone) return;
  std::atomic_ref<std::uint64_t>(bits_[entry]).store(0, std::memory_order_relaxed);
  for (std::size_t w = 0; w < words_; ++w) std::atomic_ref<std::uint64_t>(values_[entry * words_ + w]).store(0, std::memory_order_relaxed);
}

void SphereConeCache::put(std::uint32_t sphere, std::size_t cone, std::uint8_t q) const {
  if (!enabled()) return;
  std::size_t entry = sphere;
  if (slot_) {
    std::atomic_ref<std::uint32_t> slot(slot_[sphere]);
    std::uint32_t s = slot.load(std::memory_order_acquire);
    if (s == 0 && slot.compare_exchange_strong(s, kClaiming, std::memory_order_acquire)) {
      // this thread gives the sphere its entry; the others skip storing meanwhile, so none is wasted
      const std::size_t claim = claimed_.fetch_add(1, std::memory_order_relaxed);
      if (claim >= capacity_) {
        slot.store(kNoEntry, std::memory_order_relaxed);  // the pool is used up: traced every time
        return;
      }
      std::atomic_ref<std::uint64_t>(bits_[claim]).store(0, std::memory_order_relaxed);
      for (std::size_t w = 0; w < words_; ++w) std::atomic_ref<std::uint64_t>(values_[claim * words_ + w]).store(0, std::memory_order_relaxed);
      s = static_cast<std::uint32_t>(claim + 1);
      slot.store(s, std::memory_order_release);
    }
    if (s == 0 || s >= kNoEntry) return;  // being claimed by another thread, or no entry
    entry = s - 1;
  }
  // a byte of a word other cones share: or-ed in (it is 0 until stored; a cone traced twice by two
  // threads at once has the same value)
  std::atomic_ref<std::uint64_t>(values_[entry * words_ + cone / 8]).fetch_or(std::uint64_t{q} << (8 * (cone % 8)), std::memory_order_relaxed);
  std::atomic_ref<std::uint64_t>(bits_[entry]).fetch_or(std::uint64_t{1} << cone, std::memory_order_release);
}

std::size_t SphereConeCache::entries_used() const {
  if (!enabled()) return 0;
  return slot_ ? std::min(claimed_.load(std::memory_order_relaxed), capacity_) : spheres_;
}

std::size_t SphereConeCache::memory_bytes() const {
  if (!enabled()) return 0;
  return (slot_ ? spheres_ * sizeof(std::uint32_t) : 0) + entries_used() * entry_bytes();
}

}  // namespace penumbra
