// Factories of the shadow and ambient techniques for spheres (their names and keys are in
// scene/technique_catalog.h). A scene with particles uses these; a scene without uses the volume
// techniques of shadows/registry.h.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "penumbra/particles/sphere_shadow_technique.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

std::unique_ptr<SphereShadowTechnique> make_sphere_shadow_technique(const ShadowSettings& settings);
// Whether the scene's sphere techniques trace rays through the Embree BVH.
bool needs_sphere_bvh(const Scene& scene);

// nullptr for "none".
std::unique_ptr<ParticleAmbientTechnique> make_particle_ambient_technique(const AmbientSettings& settings);

// Every light reaches every point.
class NoSphereShadows final : public SphereShadowTechnique {
public:
  void build(const ParticleScene&, const Light&) override {}
  void light_fraction(std::span<const SurfacePoint>, std::span<float> out) const override {
    for (float& f : out) f = 1.0f;
  }
  std::size_t memory_bytes() const override { return 0; }
  std::string_view name() const override { return "none"; }
};

}  // namespace penumbra
