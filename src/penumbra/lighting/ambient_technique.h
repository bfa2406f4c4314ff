// The interface of ambient-occlusion techniques (DESIGN.md), for every kind of occluder and receiver:
// build() looks at the scene's occluders once (per transfer function, per particle set), ambient()
// answers, for a batch of volume samples or of surface points, which fraction of the ambient light of
// each colour reaches them. The ray caster and the surface shader multiply their ambient term by it.
#pragma once

#include <cstddef>
#include <span>
#include <string_view>

#include "penumbra/core/color.h"
#include "penumbra/core/math.h"
#include "penumbra/lighting/shadow_casters.h"
#include "penumbra/lighting/surface_point.h"

namespace penumbra {

class AmbientTechnique {
public:
  virtual ~AmbientTechnique() = default;
  // `occluders` must outlive the technique's queries.
  virtual void build(const ShadowCasters& occluders) = 0;
  virtual void ambient(std::span<const Vec3> points, std::span<Rgb> out) const = 0;
  // Points on opaque surfaces; by default queried at their positions as volume samples.
  virtual void ambient(std::span<const SurfacePoint> points, std::span<Rgb> out) const {
    for (std::size_t i = 0; i < points.size(); ++i) {
      const Vec3 p = points[i].position;
      ambient(std::span<const Vec3>(&p, 1), out.subspan(i, 1));
    }
  }
  virtual std::size_t memory_bytes() const = 0;
  virtual std::string_view name() const = 0;
  // True when build() from occluders restricted to a brick (ShadowCasters::brick) combines what the
  // brick holds with the other bricks' (accel/brick_reduction.h), giving the whole scene's structure.
  virtual bool combines_over_bricks() const { return false; }
  // False when one brick's voxels suffice in a distributed frame (ShadowTechnique::reads_whole_volume).
  virtual bool reads_whole_volume() const { return true; }
  // True when build() on a built technique reuses what the last build made (particle_ao's kept cones):
  // the renderer then builds the same object again while the ambient settings stay the same.
  virtual bool keeps_state_across_builds() const { return false; }
  // What the last build kept from the one before: particle_ao's spheres whose cones it kept.
  virtual std::size_t kept_from_last_build() const { return 0; }

  Rgb ambient(const Vec3& p) const {
    Rgb out;
    ambient(std::span<const Vec3>(&p, 1), std::span<Rgb>(&out, 1));
    return out;
  }
};

}  // namespace penumbra
