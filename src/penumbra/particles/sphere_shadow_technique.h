// The interface of shadow techniques for spheres (the particle counterpart of ShadowTechnique): build()
// looks at the spheres from one light; light_fraction() answers, for a batch of surface points, which
// fraction of that light's direct illumination reaches them — 1 lit, 0 fully shadowed, in between
// for soft shadows. A point on a sphere names it (`self`) so that the sphere does not shadow itself.
#pragma once

#include <cstddef>
#include <cstdint>
#include <span>
#include <string_view>

#include "penumbra/core/math.h"
#include "penumbra/data/particles.h"
#include "penumbra/particles/sphere_bvh.h"
#include "penumbra/scene/light.h"

namespace penumbra {

// What the particle techniques see: the spheres, their BVH and the box they fill.
struct ParticleScene {
  const ParticleSet* particles = nullptr;
  const SphereBvh* bvh = nullptr;
  Box3 bounds;
};

struct SurfacePoint {
  Vec3 position;
  Vec3 normal;                     // unit, facing the viewer
  std::uint32_t self = kNoSphere;  // the sphere the point lies on; kNoSphere for planes
};

class SphereShadowTechnique {
public:
  virtual ~SphereShadowTechnique() = default;
  virtual void build(const ParticleScene& scene, const Light& light) = 0;
  virtual void light_fraction(std::span<const SurfacePoint> points, std::span<float> out) const = 0;
  virtual std::size_t memory_bytes() const = 0;
  virtual std::string_view name() const = 0;
};

// Ambient occlusion of sphere scenes: the fraction of the ambient light reaching each point.
class ParticleAmbientTechnique {
public:
  virtual ~ParticleAmbientTechnique() = default;
  virtual void build(const ParticleScene& scene) = 0;
  virtual void ambient(std::span<const SurfacePoint> points, std::span<float> out) const = 0;
  virtual std::size_t memory_bytes() const = 0;
  virtual std::string_view name() const = 0;
};

}  // namespace penumbra
