// Linear RGB colour and RGBA samples. All shading is in linear RGB; sRGB only at 8-bit output.
#pragma once

#include <algorithm>
#include <cmath>

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

}  // namespace penumbra
