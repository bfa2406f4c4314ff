// The interface every shadow technique implements (DESIGN.md "The one idea that organises the code"):
// build() looks at the scene from one light and stores something (the papers' "generation");
// transmittance() answers, for a batch of points, how much light of each colour reaches them from that
// light (the papers' "rendering"). The ray caster calls transmittance() once per batch of samples of a
// ray, so the virtual call is paid per batch, not per sample.
#pragma once

#include <cstddef>
#include <span>
#include <string_view>

#include "penumbra/core/color.h"
#include "penumbra/core/math.h"
#include "penumbra/scene/light.h"
#include "penumbra/shadows/shadow_medium.h"

namespace penumbra {

class ShadowTechnique {
public:
  virtual ~ShadowTechnique() = default;
  virtual void build(const ShadowMedium& medium, const Light& light) = 0;
  // Per-channel transmittance in [0, 1]^3 from the light to each point; out.size() == points.size().
  virtual void transmittance(std::span<const Vec3> points, std::span<Rgb> out) const = 0;
  // A point on an opaque surface (normal n) moved towards the light just enough that the surface does
  // not shadow itself in this technique's map (slope-scaled bias for maps, an epsilon for rays).
  virtual Vec3 surface_receiver(const Vec3& p, const Vec3& n) const = 0;
  virtual std::size_t memory_bytes() const = 0;
  virtual std::string_view name() const = 0;

  Rgb transmittance(const Vec3& p) const {
    Rgb out;
    transmittance(std::span<const Vec3>(&p, 1), std::span<Rgb>(&out, 1));
    return out;
  }
};

// p moved by `epsilon` along ±n, to the side of the light: the surface offset of the techniques that
// query rays or caches rather than a depth map.
inline Vec3 offset_towards_light(const Light& light, const Vec3& p, const Vec3& n, float epsilon) {
  Vec3 to_light;
  float distance;
  light.towards(p, to_light, distance);
  return p + (dot(n, to_light) >= 0 ? n : -n) * epsilon;
}

}  // namespace penumbra
