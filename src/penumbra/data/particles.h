// A set of spheres (atoms, particles): centre and radius packed as four floats — the layout Embree's
// sphere geometry reads in place — and one packed RGBA8 colour per sphere (linear RGB). 16 M spheres
// take 320 MB. Loaders (data/io/particle_io.h) fill the colours from the chosen colouring; the
// procedural `random_spheres` set is for tests and scaling.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "penumbra/core/clip_planes.h"
#include "penumbra/core/color.h"
#include "penumbra/core/math.h"
#include "penumbra/data/color_key.h"

namespace penumbra {

// The index that names no sphere (background pixels, points on other surfaces).
constexpr std::uint32_t kNoSphere = 0xffffffffu;

struct Sphere {
  Vec3 center;
  float radius;
};
static_assert(sizeof(Sphere) == 16, "Sphere must match Embree's RTC_FORMAT_FLOAT4 (x, y, z, r)");

inline std::uint32_t pack_rgba8(const Rgb& c) {
  auto q = [](float v) { return static_cast<std::uint32_t>(clamp(v, 0, 1) * 255.0f + 0.5f); };
  return q(c.r) | (q(c.g) << 8) | (q(c.b) << 16) | (255u << 24);
}
inline Rgb unpack_rgb8(std::uint32_t p) {
  constexpr float k = 1.0f / 255.0f;
  return Rgb{static_cast<float>(p & 255u) * k, static_cast<float>((p >> 8) & 255u) * k,
             static_cast<float>((p >> 16) & 255u) * k};
}

struct ParticleSet {
  std::vector<Sphere> spheres;
  std::vector<std::uint32_t> colors;  // pack_rgba8, linear RGB; same size as spheres
  // Per sphere, the 0-based index in its file of the atom it draws, when the spheres are a selection
  // of a file's atoms (particles[].select; an assembly's copies name the atom copied); empty otherwise.
  std::vector<std::uint32_t> atoms;
  // The frame's spheres under clip planes (set by the renderer; empty otherwise): per sphere whole,
  // removed, or the mask of `clip_planes` that cut it (geometry/cut_sphere.h intersects it).
  std::vector<SphereClip> clip_state;
  ClipPlanes clip_planes;
  ColorKey color_key;               // what the colours mean (loaders fill it; empty for arrays)
  std::optional<PeriodicBox> box;   // the periodic cell the file stores (a trajectory: this frame's)
  SphereClip clip_of(std::size_t i) const { return clip_state.empty() ? kSphereWhole : clip_state[i]; }

  std::size_t size() const { return spheres.size(); }
  Box3 bounds() const;          // of the spheres not clipped away (centre ± radius); empty when there are none
  std::size_t memory_bytes() const {
    return spheres.capacity() * sizeof(Sphere) + (colors.capacity() + atoms.capacity()) * sizeof(std::uint32_t) +
           clip_state.capacity();
  }
};

// `count` spheres of radius `radius` with centres uniform in the cube [-0.5, 0.5]³, colours from a
// hashed hue; deterministic for a seed.
ParticleSet random_spheres(std::size_t count, float radius, std::uint64_t seed);

}  // namespace penumbra
