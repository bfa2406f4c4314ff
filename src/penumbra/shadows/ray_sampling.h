// Sample patterns of the ray-traced references (area-light shadows, ambient occlusion): a fixed
// stratified set of points on the unit square, rotated per receiver by a hash of its position
// (Cranley–Patterson), so results are deterministic and the same for any thread count.
#pragma once

#include <bit>
#include <cmath>

#include "penumbra/core/math.h"
#include "penumbra/core/rng.h"

namespace penumbra {

// A receiver's random rotation of the sample pattern, hashed from its position.
inline void pattern_rotation(const Vec3& p, float& r1, float& r2) {
  const std::uint64_t h = hash_keys(0x5eed, std::bit_cast<std::uint32_t>(p.x), std::bit_cast<std::uint32_t>(p.y),
                                    std::bit_cast<std::uint32_t>(p.z));
  r1 = to_unit_float(h);
  r2 = to_unit_float(mix64(h));
}

// Sample i of n on the unit square: a rotated Fibonacci lattice (stratified in both coordinates).
inline void lattice_sample(int i, int n, float r1, float r2, float& u1, float& u2) {
  constexpr float kGolden = 0.618033988749895f;
  u1 = (static_cast<float>(i) + 0.5f) / static_cast<float>(n) + r1;
  u2 = static_cast<float>(i) * kGolden + r2;
  u1 -= std::floor(u1);
  u2 -= std::floor(u2);
}

// Uniform over the cap of directions within acos(cos_max) of +z.
inline Vec3 cone_direction(float u1, float u2, float cos_max) {
  const float cos_t = 1.0f - u1 * (1.0f - cos_max);
  const float sin_t = std::sqrt(std::max(0.0f, 1.0f - cos_t * cos_t));
  const float phi = 2.0f * kPi * u2;
  return Vec3{sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t};
}

// Cosine-weighted over the hemisphere around +z (Malley: uniform on the disc, lifted).
inline Vec3 cosine_direction(float u1, float u2) {
  const float r = std::sqrt(u1);
  const float phi = 2.0f * kPi * u2;
  return Vec3{r * std::cos(phi), r * std::sin(phi), std::sqrt(std::max(0.0f, 1.0f - u1))};
}

// Uniform over the whole sphere.
inline Vec3 sphere_direction(float u1, float u2) { return cone_direction(u1, u2, -1.0f); }

}  // namespace penumbra
