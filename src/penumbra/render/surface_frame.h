// The opaque surfaces of a frame — spheres, isosurfaces and planes — found per pixel and shaded.
// visible_surfaces() takes, per pixel, the nearest of the sphere hit (SphereHits), the isosurfaces' eye
// points and the planes, and lists it as a SurfacePoint (in pixel order, the same for any thread
// count). shade_surfaces() shades them in batches with Blinn–Phong under every light, each light's
// direct term scaled by its LightShadows' per-channel transmittance (coloured where translucent
// volumes cast), the ambient term by the ambient technique and the diffuse term by its grey mean (paper
// 003 §4 adds AO "in completely unshadowed" regions too). Isosurfaces and spheres get a highlight, planes are
// Lambertian. The result carries each pixel's distance, so that the volumes are then ray cast in front
// of it (render_volume_frame's OpaqueLayer).
#pragma once

#include <span>
#include <vector>

#include "penumbra/core/image.h"
#include "penumbra/geometry/iso_point.h"
#include "penumbra/particles/sphere_hits.h"
#include "penumbra/render/light_shadows.h"
#include "penumbra/scene/scene.h"
#include "penumbra/lighting/ambient_technique.h"

namespace penumbra {

struct VisibleSurfaces {
  std::vector<SurfacePoint> points;
  std::vector<std::uint32_t> pixel;  // pixel index of each point
  std::vector<Rgb> albedo;
  std::vector<std::uint8_t> receives;  // the object receives shadows
  std::vector<float> distance;         // per pixel: distance to the opaque surface; infinity: background
  std::vector<std::uint32_t> what;     // per pixel: what it shows (kind in the top two bits; plane index)
};

struct SurfaceInputs {
  const Scene* scene;
  const Camera* camera;
  const ParticleSet* particles = nullptr;   // the frame's spheres (casting objects first)
  std::span<const std::uint32_t> particle_offsets;  // first sphere of each segment of the set, then the total
  std::span<const std::uint32_t> particle_objects;  // the scene's particle object of each segment
  const SphereHits* hits = nullptr;
  std::span<const IsoPoints> isosurface_points;  // one eye pass per scene isosurface
};

// Fills `out` (reusing its buffers: a renderer keeps one across frames).
void visible_surfaces(const SurfaceInputs& in, VisibleSurfaces& out);
inline VisibleSurfaces visible_surfaces(const SurfaceInputs& in) {
  VisibleSurfaces out;
  visible_surfaces(in, out);
  return out;
}

// Per pixel the nearest translucent plane (a slice with opacity below 1) in front of the opaque surface
// at `opaque_distance`: its points for shade_surfaces (what: the plane's index), its distance (infinity
// where none) and `opacity` per pixel (0 where none). Everything empty, per-pixel buffers included,
// when the scene has no translucent plane.
void translucent_surfaces(const Scene& scene, const Camera& camera, const std::vector<float>& opaque_distance, VisibleSurfaces& out,
                          std::vector<float>& opacity);
bool has_translucent_planes(const Scene& scene);

// The shaded surfaces over the background.
Image shade_surfaces(const Scene& scene, const Camera& camera, const VisibleSurfaces& surfaces, std::span<const Light> lights,
                     std::span<const LightShadows* const> shadows, const AmbientTechnique* ambient);

}  // namespace penumbra
