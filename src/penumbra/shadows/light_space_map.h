// Shared machinery of the shadow maps (classic, deep, CSSM): the fitted light projection, the n x n
// texel grid, a parallel loop over texel rays for build(), receiver depth with bias, and the
// slope-scaled offset for surface receivers.
#pragma once

#include <functional>

#include "penumbra/scene/scene.h"
#include "penumbra/scene/light_projection.h"
#include "penumbra/lighting/shadow_technique.h"
#include "penumbra/lighting/shared_params.h"

namespace penumbra {

class LightSpaceMap : public ShadowTechnique {
public:
  explicit LightSpaceMap(const TechniqueParams& params)
      : resolution_(static_cast<int>(kMapResolution.integer(params))), bias_setting_(static_cast<float>(kMapBias.number(params))) {}

  void build(const ShadowCasters& medium, const Light& light) final;
  Vec3 surface_receiver(const Vec3& p, const Vec3& n) const final;

  int resolution() const { return resolution_; }
  const LightProjection& projection() const { return projection_; }

protected:
  // Fills the map: called once per build after the projection is fitted.
  virtual void build_map(const ShadowCasters& medium) = 0;
  // Calls texel(ix, iy, ray) for every texel, rows in parallel; `ray` goes from the light through the
  // texel centre with t = light depth.
  void for_each_texel(const std::function<void(int ix, int iy, const Ray& ray)>& texel) const;
  // Light depth of the first opaque surface on a texel ray (projection().caster_t_begin() onwards), or
  // infinity: the depth every map technique stops its walk at.
  float first_surface(const ShadowCasters& medium, const Ray& ray) const {
    return medium.surface_hit(ray, projection_.caster_t_begin(), kInfinity);
  }
  // Texel of p and its biased depth; false when p is outside the map (then it is lit: nothing that
  // casts a shadow lies outside the frustum).
  bool locate(const Vec3& p, int& ix, int& iy, float& depth) const {
    float u, v;
    if (!projection_.project(p, u, v, depth)) return false;
    ix = std::min(static_cast<int>(u * static_cast<float>(resolution_)), resolution_ - 1);
    iy = std::min(static_cast<int>(v * static_cast<float>(resolution_)), resolution_ - 1);
    depth -= bias_;
    return true;
  }
  // out[i] = at_texel(ix, iy, biased depth) for the points inside the map, 1 (lit) for the others.
  template <class AtTexel>
  void query(std::span<const Vec3> points, std::span<Rgb> out, AtTexel&& at_texel) const {
    for (std::size_t i = 0; i < points.size(); ++i) {
      int ix, iy;
      float depth;
      out[i] = locate(points[i], ix, iy, depth) ? at_texel(ix, iy, depth) : Rgb(1.0f);
    }
  }
  std::size_t texel_index(int ix, int iy) const { return static_cast<std::size_t>(iy) * resolution_ + ix; }

  int resolution_;
  int filter_radius_ = 0;  // texels a query reads away from its own (PCF, CSSM offsets)
  float bias_setting_;
  float bias_ = 0;
  LightProjection projection_;
  Light light_;
};

}  // namespace penumbra
