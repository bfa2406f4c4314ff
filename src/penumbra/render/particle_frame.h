// Shading of a sphere frame: every pixel whose nearest opaque surface is a sphere (from SphereHits) or
// a plane becomes a SurfacePoint; the points are shaded in batches with Blinn–Phong under every light,
// each light's direct term scaled by its SphereShadowTechnique's light fraction (paper 003 §3.2 end:
// fully shadowed points keep only the ambient term, partly shadowed ones a weighted diffuse and
// specular), and the ambient and diffuse terms by the particle ambient technique (so that AO shows in
// lit regions too: the paper's §4 adds it "in completely unshadowed ones"). Planes are Lambertian
// receivers of the same shadows. The result carries each pixel's distance to its opaque surface so that a volume
// can be composited in front of it (render_volume_frame's OpaqueLayer).
#pragma once

#include <span>
#include <vector>

#include "penumbra/core/image.h"
#include "penumbra/particles/implicit_sphere_shadow_map.h"
#include "penumbra/particles/sphere_hits.h"
#include "penumbra/particles/sphere_shadow_technique.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

struct ParticleFrameInputs {
  const Scene* scene;
  const Camera* camera;
  const ParticleSet* particles;
  const SphereHits* hits;
  std::span<const Light> lights;
  std::span<const SphereShadowTechnique* const> shadows;  // one per light
  const ParticleAmbientTechnique* ambient = nullptr;       // null: unoccluded
};

// The visible opaque surfaces of a frame, pixel by pixel (kNoSphere/plane index tell what they are).
struct VisibleSurfaces {
  std::vector<SurfacePoint> points;
  std::vector<std::uint32_t> pixel;  // pixel index of each point
  std::vector<Rgb> albedo;
  std::vector<float> distance;       // per pixel: distance to the opaque surface; infinity: background
};

VisibleSurfaces visible_surfaces(const ParticleFrameInputs& in);

// The shaded spheres and planes over the background (each pixel's distance is surfaces.distance).
Image shade_particle_frame(const ParticleFrameInputs& in, const VisibleSurfaces& surfaces);

// The automatic choice of t (paper 003 §4): t grows from 0 until the frame's light fractions stop
// changing — at most `max_changed` of the points change by more than 1/255 — or t reaches max_rings.
// Leaves the map at the chosen t and returns it.
int choose_issm_rings(ImplicitSphereShadowMap& map, std::span<const SurfacePoint> points, int max_rings = 8,
                      double max_changed = 1e-4);

}  // namespace penumbra
