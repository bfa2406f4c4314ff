// ParticleSet bounds and the procedural random sphere set.
#include "penumbra/data/particles.h"

#include <cmath>

#include "penumbra/core/rng.h"

namespace penumbra {

Box3 ParticleSet::bounds() const {
  Box3 b;
  for (std::size_t i = 0; i < spheres.size(); ++i) {
    if (clip_of(i) == kSphereRemoved) continue;  // clipped away: nothing of it is drawn or casts
    const Sphere& s = spheres[i];
    const Vec3 r{s.radius, s.radius, s.radius};
    b.lo = min(b.lo, s.center - r);
    b.hi = max(b.hi, s.center + r);
  }
  return b;
}

namespace {

// Fully saturated-ish hue on the sRGB colour wheel (s = 0.6, v = 0.9), returned as linear RGB.
Rgb hue_color(float hue) {
  const float h = hue * 6.0f;
  const float s = 0.6f, v = 0.9f;
  const int sector = static_cast<int>(h) % 6;
  const float f = h - std::floor(h);
  const float p = v * (1 - s), q = v * (1 - s * f), t = v * (1 - s * (1 - f));
  Rgb c;
  switch (sector) {
    case 0: c = {v, t, p}; break;
    case 1: c = {q, v, p}; break;
    case 2: c = {p, v, t}; break;
    case 3: c = {p, q, v}; break;
    case 4: c = {t, p, v}; break;
    default: c = {v, p, q}; break;
  }
  return {srgb_to_linear(c.r), srgb_to_linear(c.g), srgb_to_linear(c.b)};
}

}  // namespace

ParticleSet random_spheres(std::size_t count, float radius, std::uint64_t seed) {
  ParticleSet set;
  set.spheres.resize(count);
  set.colors.resize(count);
  for (std::size_t i = 0; i < count; ++i) {
    // Keys (i, 0..2) draw the centre, key (i, 3) the hue: each sphere depends on (seed, i) alone.
    const Vec3 c{uniform_float(seed, i, 0) - 0.5f, uniform_float(seed, i, 1) - 0.5f, uniform_float(seed, i, 2) - 0.5f};
    set.spheres[i] = Sphere{c, radius};
    set.colors[i] = pack_rgba8(hue_color(uniform_float(seed, i, 3)));
  }
  return set;
}

}  // namespace penumbra
