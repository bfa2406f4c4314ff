#include "penumbra/shadows/ray_traced.h"

#include "penumbra/lighting/shared_params.h"
#include "penumbra/shadows/ray_sampling.h"

namespace penumbra {

void RayTracedShadows::build(const ShadowCasters& casters, const Light& light) {
  casters_ = &casters;
  light_ = light;
  tan_light_radius_ = std::tan(radians(light_angle_deg_));
  centre_ = casters.bounds().empty() ? Vec3{0, 0, 0} : casters.bounds().center();
}

Rgb RayTracedShadows::exact(const Vec3& origin, const Vec3& key) const {
  Vec3 to_light;
  float distance;
  light_.towards(origin, to_light, distance);
  if (light_angle_deg_ <= 0 || area_rays_ <= 1) return casters_->transmittance(Ray{origin, to_light}, 0, distance, refined_);
  // A round light: its angular radius is fixed for directional lights; point and spot lights are balls
  // whose radius subtends light_angle at the casters' centre.
  float tan_radius = tan_light_radius_;
  if (light_.type != LightType::Directional && distance > 0)
    tan_radius = tan_light_radius_ * length(light_.position - centre_) / distance;
  const float cos_max = 1.0f / std::sqrt(1.0f + tan_radius * tan_radius);
  const Frame frame = Frame::from_w(to_light);
  float r1, r2;
  pattern_rotation(key, r1, r2);
  Rgb sum(0.0f);
  for (int i = 0; i < area_rays_; ++i) {
    float u1, u2;
    lattice_sample(i, area_rays_, r1, r2, u1, u2);
    sum += casters_->transmittance(Ray{origin, frame.to_world(cone_direction(u1, u2, cos_max))}, 0, distance, refined_);
  }
  return sum * (1.0f / static_cast<float>(area_rays_));
}

void RayTracedShadows::transmittance(std::span<const Vec3> points, std::span<Rgb> out) const {
  for (std::size_t i = 0; i < points.size(); ++i) out[i] = exact(points[i], points[i]);
}

void RayTracedShadows::transmittance(std::span<const SurfacePoint> points, std::span<Rgb> out) const {
  for (std::size_t i = 0; i < points.size(); ++i) {
    Vec3 to_light;
    float distance;
    light_.towards(points[i].position, to_light, distance);
    out[i] = exact(casters_->ray_origin(points[i], to_light), points[i].position);
  }
}

namespace {
const ParamSpec kLightAngle = number_param("light_angle", 0, 0, 45, "degrees", "angular radius of the light on spheres (0: a point, one ray; > 0: an area light sampled with area_rays); point and spot lights: the radius subtending it at the scene centre");
const ParamSpec kAreaRays = integer_param("area_rays", 64, 1, 65536, "rays", "shadow rays per receiver when light_angle > 0", ParamRole::RayCount);
}  // namespace

const TechniqueInfo& ray_traced_technique() {
  static const TechniqueInfo info{
      "ray_traced", TechniqueFamily::Shadow, kAllKinds,
      "exact: a light ray from every receiver through every caster (the reference the others are measured against)",
      {kLightStep, kLightAngle, kAreaRays},
      {.sphere_rays = true},
      [](const TechniqueParams& p) -> std::unique_ptr<ShadowTechnique> {
        return std::make_unique<RayTracedShadows>(static_cast<float>(kLightAngle.number(p)), static_cast<int>(kAreaRays.integer(p)));
      },
      {}};
  return info;
}

const TechniqueInfo& no_shadows_technique() {
  static const TechniqueInfo info{"none", TechniqueFamily::Shadow, kAllKinds, "no shadows", {}, {},
                                  [](const TechniqueParams&) -> std::unique_ptr<ShadowTechnique> { return std::make_unique<NoShadows>(); },
                                  {}};
  return info;
}

}  // namespace penumbra
