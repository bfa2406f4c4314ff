// The one interface every shadow technique implements, for every kind of caster and receiver
// (DESIGN.md "The one idea that organises the code"): build() looks at the casters from one light and
// stores something (the papers' "generation"); transmittance() answers, for a batch of volume samples
// or of surface points, how much light of each colour reaches them from that light (the papers'
// "rendering"). The ray caster asks once per batch of samples of a ray and the surface shader once per
// batch of points, so the virtual call is paid per batch, not per sample. A surface point names its
// object (SurfacePoint), so that nothing shadows itself.
#pragma once

#include <array>
#include <cstddef>
#include <span>
#include <string_view>

#include "penumbra/core/color.h"
#include "penumbra/core/math.h"
#include "penumbra/scene/light.h"
#include "penumbra/lighting/shadow_casters.h"
#include "penumbra/lighting/surface_point.h"

namespace penumbra {

// What a technique did this frame that a user may want to see (render --stats).
struct ShadowStats {
  int issm_rings = -1;           // issm: the rings t used (chosen this frame when automatic)
  std::size_t light_points = 0;  // light_pass: points extracted from the lights
  std::size_t holes = 0;         // light_pass: light pixels punched by the receivers (paper 002 §4.2)
};

class ShadowTechnique {
public:
  virtual ~ShadowTechnique() = default;
  // `casters` (the kinds this technique covers) must outlive the technique's queries.
  virtual void build(const ShadowCasters& casters, const Light& light) = 0;
  // Called every frame, before any query, with the frame's visible surface points; `volume_samples`
  // says whether volume samples will query too; `refined`, whether the receivers were drawn from refined
  // boxes (a full frame, render/view_refinement.h), whose casters may then serve too, or from the opened
  // levels (a preview). View-dependent work happens here (paper 002 §4: the light pass answers only for
  // the eye's points; paper 003 §4: ISSM's automatic rings).
  virtual void fit_to_receivers(std::span<const SurfacePoint> /*receivers*/, bool /*volume_samples*/, bool /*refined*/) {}
  // Whether fit_to_receivers rebuilds the structure (then every frame reports "shadows" rebuilt).
  virtual bool view_dependent() const { return false; }
  // True when build() from casters restricted to a brick (ShadowCasters::brick) builds the brick's
  // partial structure and combines it over the bricks (shadow_brick.h), giving the whole scene's.
  virtual bool combines_over_bricks() const { return false; }
  // False when one brick's voxels suffice in a distributed frame (distributed/brick_reading.h): the
  // technique combines over bricks, or reads the volume only through the extinction SAT, which is
  // summed over the bricks.
  virtual bool reads_whole_volume() const { return !combines_over_bricks(); }
  // Per-channel transmittance in [0, 1]^3 from the light to each volume sample.
  virtual void transmittance(std::span<const Vec3> points, std::span<Rgb> out) const = 0;
  // The same for points on opaque surfaces. By default each point is moved by surface_receiver and
  // queried as a volume sample.
  virtual void transmittance(std::span<const SurfacePoint> points, std::span<Rgb> out) const {
    std::array<Vec3, 64> moved;
    for (std::size_t b = 0; b < points.size(); b += moved.size()) {
      const std::size_t n = std::min(moved.size(), points.size() - b);
      for (std::size_t i = 0; i < n; ++i) moved[i] = surface_receiver(points[b + i].position, points[b + i].normal);
      transmittance(std::span<const Vec3>(moved.data(), n), out.subspan(b, n));
    }
  }
  // A point on an opaque surface (normal n) moved towards the light just enough that the surface does
  // not shadow itself in this technique's map (slope-scaled bias for maps, an epsilon for rays).
  virtual Vec3 surface_receiver(const Vec3& p, const Vec3& n) const = 0;
  virtual void add_stats(ShadowStats& /*stats*/) const {}
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
