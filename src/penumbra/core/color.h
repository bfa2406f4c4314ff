// Linear RGB colour and RGBA samples. All shading is in linear RGB; sRGB only at 8-bit output.
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>

namespace penumbra {

struct Rgb {
  float r = 0, g = 0, b = 0;
  constexpr Rgb() = default;
  constexpr explicit Rgb(float v) : r(v), g(v), b(v) {}
  constexpr Rgb(float r_, float g_, float b_) : r(r_), g(g_), b(b_) {}
  constexpr float operator[](int i) const { return i == 0 ? r : (i == 1 ? g : b); }
  constexpr float& operator[](int i) { return i == 0 ? r : (i == 1 ? g : b); }
  constexpr Rgb operator+(const Rgb& o) const { return {r + o.r, g + o.g, b + o.b}; }
  constexpr Rgb operator-(const Rgb& o) const { return {r - o.r, g - o.g, b - o.b}; }
  constexpr Rgb operator*(const Rgb& o) const { return {r * o.r, g * o.g, b * o.b}; }
  constexpr Rgb operator*(float s) const { return {r * s, g * s, b * s}; }
  constexpr Rgb& operator+=(const Rgb& o) { r += o.r; g += o.g; b += o.b; return *this; }
  constexpr Rgb& operator*=(const Rgb& o) { r *= o.r; g *= o.g; b *= o.b; return *this; }
  constexpr Rgb& operator*=(float s) { r *= s; g *= s; b *= s; return *this; }
  constexpr bool operator==(const Rgb&) const = default;
  constexpr float max_component() const { return std::max(r, std::max(g, b)); }
  constexpr float average() const { return (r + g + b) / 3.0f; }
};
constexpr Rgb operator*(float s, const Rgb& c) { return c * s; }

struct Rgba {
  Rgb rgb;
  float a = 0;
};

inline float linear_to_srgb(float v) {
  v = std::clamp(v, 0.0f, 1.0f);
  return v <= 0.0031308f ? 12.92f * v : 1.055f * std::pow(v, 1.0f / 2.4f) - 0.055f;
}
inline float srgb_to_linear(float v) {
  return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
}

namespace detail {
// steps[k]: the smallest float whose sRGB byte exceeds k (steps[255] = infinity); below[i]: a byte no
// larger than that of any value in [i/4096, (i+1)/4096) (so that a few comparisons finish the count).
struct SrgbByteTable {
  std::array<float, 256> steps;
  std::array<std::uint8_t, 4097> below;
};
extern const SrgbByteTable srgb_byte_table;
}  // namespace detail

// The sRGB byte of a linear value: exactly lround(linear_to_srgb(v) * 255) (NaN gives 0), as the number
// of steps at or below v, counted from a table's lower bound, so a frame costs no pow per pixel.
inline std::uint8_t linear_to_srgb8(float v) {
  if (!(v > 0)) return 0;  // also NaN
  if (v >= 1) return 255;
  const auto& t = detail::srgb_byte_table;
  unsigned b = t.below[static_cast<std::size_t>(v * 4096.0f)];
  // `below` is one bucket back, and two buckets (2/4096) hold at most two steps (the closest lie
  // 1/(255 · 12.92) apart, on the linear segment): two comparisons, no branch
  b += v >= t.steps[b] ? 1u : 0u;
  b += v >= t.steps[b] ? 1u : 0u;
  return static_cast<std::uint8_t>(b);
}

}  // namespace penumbra
