// Counter-based random numbers: a value is a pure function of (key..., seed), never of the order in
// which threads ask, so the same seed gives the same image for any thread count (DESIGN.md "Randomness").
#pragma once

#include <cstdint>

namespace penumbra {

// 64-bit finaliser of SplitMix64 / MurmurHash3: a bijective avalanche mix.
constexpr std::uint64_t mix64(std::uint64_t z) {
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

constexpr std::uint64_t hash_keys(std::uint64_t seed, std::uint64_t a, std::uint64_t b = 0,
                                  std::uint64_t c = 0) {
  std::uint64_t h = mix64(seed + 0x9e3779b97f4a7c15ULL);
  h = mix64(h ^ (a + 0x9e3779b97f4a7c15ULL));
  h = mix64(h ^ (b + 0x632be59bd9b4e019ULL));
  h = mix64(h ^ (c + 0x85157af5ULL));
  return h;
}

// Uniform float in [0, 1) from the top 24 bits of a 64-bit hash.
constexpr float to_unit_float(std::uint64_t h) { return static_cast<float>(h >> 40) * (1.0f / 16777216.0f); }

// A stream of numbers keyed by (seed, a, b) and an index: the key is hashed once, each number costs one
// mix. Used where one key draws many numbers (a CSSM texel's segments).
struct RandomStream {
  std::uint64_t key;
  constexpr RandomStream(std::uint64_t seed, std::uint64_t a, std::uint64_t b = 0) : key(hash_keys(seed, a, b)) {}
  constexpr float operator()(std::uint64_t index) const { return to_unit_float(mix64(key ^ (index * 0x9e3779b97f4a7c15ULL))); }
};

// Uniform float in [0, 1) from the top 24 bits of the hash.
constexpr float uniform_float(std::uint64_t seed, std::uint64_t a, std::uint64_t b = 0,
                              std::uint64_t c = 0) {
  return static_cast<float>(hash_keys(seed, a, b, c) >> 40) * (1.0f / 16777216.0f);
}

}  // namespace penumbra
