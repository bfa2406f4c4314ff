// Small vector algebra for the renderer: 3-vectors of float, a 4x4 matrix for light and camera
// projections, and an axis-aligned box with ray clipping.
#pragma once

#include <algorithm>
#include <cmath>
#include <limits>

namespace penumbra {

constexpr float kPi = 3.14159265358979323846f;
constexpr float kInfinity = std::numeric_limits<float>::infinity();

struct Vec3 {
  float x = 0, y = 0, z = 0;
  constexpr Vec3() = default;
  constexpr Vec3(float x_, float y_, float z_) : x(x_), y(y_), z(z_) {}
  constexpr float operator[](int i) const { return i == 0 ? x : (i == 1 ? y : z); }
  constexpr float& operator[](int i) { return i == 0 ? x : (i == 1 ? y : z); }
  constexpr Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
  constexpr Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
  constexpr Vec3 operator-() const { return {-x, -y, -z}; }
  constexpr Vec3 operator*(float s) const { return {x * s, y * s, z * s}; }
  constexpr Vec3 operator/(float s) const { return {x / s, y / s, z / s}; }
  constexpr Vec3 operator*(const Vec3& o) const { return {x * o.x, y * o.y, z * o.z}; }
  constexpr Vec3& operator+=(const Vec3& o) { x += o.x; y += o.y; z += o.z; return *this; }
  constexpr Vec3& operator*=(float s) { x *= s; y *= s; z *= s; return *this; }
  constexpr bool operator==(const Vec3&) const = default;
};
constexpr Vec3 operator*(float s, const Vec3& v) { return v * s; }
constexpr float dot(const Vec3& a, const Vec3& b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
constexpr Vec3 cross(const Vec3& a, const Vec3& b) {
  return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline float length(const Vec3& v) { return std::sqrt(dot(v, v)); }
inline Vec3 normalize(const Vec3& v) {
  const float l = length(v);
  return l > 0 ? v / l : Vec3{0, 0, 0};
}
constexpr Vec3 min(const Vec3& a, const Vec3& b) {
  return {std::min(a.x, b.x), std::min(a.y, b.y), std::min(a.z, b.z)};
}
constexpr Vec3 max(const Vec3& a, const Vec3& b) {
  return {std::max(a.x, b.x), std::max(a.y, b.y), std::max(a.z, b.z)};
}
inline bool is_finite(const Vec3& v) {
  return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z);
}

// Orthonormal basis (u, v, w) with w along the given direction.
struct Frame {
  Vec3 u, v, w;
  static Frame from_w(const Vec3& w_dir, const Vec3& up_hint = {0, 1, 0}) {
    Frame f;
    f.w = normalize(w_dir);
    Vec3 up = std::abs(dot(f.w, normalize(up_hint))) > 0.999f ? Vec3{1, 0, 0} : up_hint;
    if (std::abs(dot(f.w, normalize(up))) > 0.999f) up = {0, 0, 1};
    f.u = normalize(cross(up, f.w));
    f.v = cross(f.w, f.u);
    return f;
  }
  Vec3 to_local(const Vec3& p) const { return {dot(p, u), dot(p, v), dot(p, w)}; }
  Vec3 to_world(const Vec3& l) const { return u * l.x + v * l.y + w * l.z; }
};

struct Ray {
  Vec3 origin;
  Vec3 direction;  // unit length
  Vec3 at(float t) const { return origin + direction * t; }
};

struct Box3 {
  Vec3 lo{kInfinity, kInfinity, kInfinity};
  Vec3 hi{-kInfinity, -kInfinity, -kInfinity};
  bool empty() const { return lo.x > hi.x || lo.y > hi.y || lo.z > hi.z; }
  void extend(const Vec3& p) { lo = min(lo, p); hi = max(hi, p); }
  void extend(const Box3& b) { if (!b.empty()) { extend(b.lo); extend(b.hi); } }
  Vec3 center() const { return (lo + hi) * 0.5f; }
  Vec3 extent() const { return hi - lo; }
  float radius() const { return 0.5f * length(hi - lo); }
  Vec3 corner(int i) const { return {(i & 1) ? hi.x : lo.x, (i & 2) ? hi.y : lo.y, (i & 4) ? hi.z : lo.z}; }
  bool contains(const Vec3& p) const {
    return p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y && p.z >= lo.z && p.z <= hi.z;
  }
  // Slab test: the parametric interval [t0, t1] of the ray inside the box, clipped to [tmin, tmax].
  bool clip(const Ray& r, float& t0, float& t1, float tmin = 0, float tmax = kInfinity) const {
    t0 = tmin;
    t1 = tmax;
    for (int a = 0; a < 3; ++a) {
      const float inv = 1.0f / r.direction[a];
      float tn = (lo[a] - r.origin[a]) * inv;
      float tf = (hi[a] - r.origin[a]) * inv;
      if (tn > tf) std::swap(tn, tf);
      if (std::isnan(tn) || std::isnan(tf)) {  // ray parallel to the slab and on its plane
        if (r.origin[a] < lo[a] || r.origin[a] > hi[a]) return false;
        continue;
      }
      t0 = std::max(t0, tn);
      t1 = std::min(t1, tf);
      if (t0 > t1) return false;
    }
    return true;
  }
};

// floor and ceil to int without the libm call the baseline x86-64 target makes of std::floor (hot
// loops: splat footprints, cone cuboids, density-volume cells); valid for |x| < 2^31.
inline int floor_int(float x) {
  const int i = static_cast<int>(x);
  return i - (x < static_cast<float>(i) ? 1 : 0);
}
inline int ceil_int(float x) {
  const int i = static_cast<int>(x);
  return i + (x > static_cast<float>(i) ? 1 : 0);
}

inline float clamp(float v, float lo, float hi) { return std::min(std::max(v, lo), hi); }
inline float radians(float deg) { return deg * kPi / 180.0f; }

}  // namespace penumbra
