// Blinn–Phong for opaque surfaces (spheres, isosurface points, planes): the direct light one light
// adds at a surface point, before its shadow fraction. Shared by the sphere and the isosurface frames.
#pragma once

#include <cmath>

#include "penumbra/core/color.h"
#include "penumbra/core/math.h"
#include "penumbra/scene/light.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

// The n·h below which the Blinn–Phong highlight adds under 1e-4 of the light (its pow is skipped
// there); above every cosine when the shading has no highlight (`specular` 0).
inline float highlight_cutoff(const ShadingParams& k) { return k.specular > 0 ? std::pow(1e-4f, 1.0f / k.shininess) : 2.0f; }

class SurfaceShading {
public:
  explicit SurfaceShading(const ShadingParams& k) : k_(k), specular_cutoff_(highlight_cutoff(k)) {}

  // Diffuse (scaled by `diffuse_scale`, e.g. ambient occlusion) plus, when `specular`, the highlight
  // seen from `eye`; zero where the light is behind the surface.
  Rgb direct(const Light& light, const Vec3& position, const Vec3& normal, const Vec3& eye, const Rgb& albedo,
             bool specular, float diffuse_scale = 1) const {
    Vec3 to_light;
    float distance;
    light.towards(position, to_light, distance);
    const float ndotl = dot(normal, to_light);
    if (ndotl <= 0) return Rgb(0.0f);
    float spec = 0;
    if (specular && specular_cutoff_ <= 1) {  // (no highlight at all: not even its half vector)
      const float ndoth = dot(normal, normalize(to_light + normalize(eye - position)));
      if (ndoth > specular_cutoff_) spec = std::pow(ndoth, k_.shininess);
    }
    return light.emitted(to_light) * (albedo * (k_.diffuse * ndotl * diffuse_scale) + Rgb(k_.specular * spec));
  }

private:
  const ShadingParams& k_;
  float specular_cutoff_;  // below this n·h the highlight is under 1e-4
};

}  // namespace penumbra
