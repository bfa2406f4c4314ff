#include "penumbra/shadows/sat_cone.h"

#include <cmath>
#include <optional>

#include "penumbra/lighting/shared_params.h"

namespace penumbra {

namespace {
const ParamSpec kConeAngle = number_param("cone_angle", 5, 0, 89.9, "degrees", "half-angle of the cone towards the light (paper 001 §3.3)");
const ParamSpec kConeSamples = number_param("cone_samples", 50, 1, 4096, "cuboids", "cuboids per longest side of the light cache, before growth");
const ParamSpec kConeGrowth = number_param("cone_growth", 0, 0, 1, "", "relative growth of each cuboid's thickness over the previous one");
const ParamSpec kConeRays = integer_param("cone_rays", 64, 1, 4096, "rays", "exact shadow rays spread over the cone", ParamRole::RayCount);
}  // namespace

const TechniqueInfo& sat_cone_technique() {
  static const TechniqueInfo info{"sat_cone", TechniqueFamily::Shadow, kAllKinds,
                                  "soft shadows: the extinction in a cone towards the light, from cuboids of the 3D summed area table (Schlegel et al.)",
                                  {kConeAngle, kConeSamples, kConeGrowth},
                                  {.extinction_sat = true, .sphere_rays = true},
                                  shadow_factory<SatConeShadows>(),
                                  {}};
  return info;
}

const TechniqueInfo& sampled_cone_technique() {
  static const TechniqueInfo info{"sampled_cone", TechniqueFamily::Shadow, kAllKinds,
                                  "the cone's reference: exact shadow rays spread over the cone sat_cone approximates",
                                  {kLightStep, kConeAngle, kConeRays},
                                  {.sphere_rays = true},
                                  shadow_factory<SampledConeShadows>(),
                                  {}};
  return info;
}

SampledConeShadows::SampledConeShadows(const TechniqueParams& params)
    : half_angle_(radians(static_cast<float>(kConeAngle.number(params)))), rays_(static_cast<int>(kConeRays.integer(params))) {}

SatConeShadows::SatConeShadows(const TechniqueParams& params) {
  sampling_.half_angle = radians(static_cast<float>(kConeAngle.number(params)));
  sampling_.samples_per_unit = static_cast<float>(kConeSamples.number(params));
  sampling_.growth = static_cast<float>(kConeGrowth.number(params));
}

float SatConeShadows::attenuation(const Vec3& p) const {
  Vec3 to_light;
  float distance;
  light_.towards(p, to_light, distance);
  const Ray ray{p, to_light};
  if (medium_->surface_hit(ray, epsilon_, distance) < kInfinity) return 0.0f;
  const Box3& box = sat_->bounds();
  if (!box.contains(p)) {  // a receiver outside (a plane): lit unless the cone can reach the grid
    float reach = 0;
    for (int c = 0; c < 8; ++c) reach = std::max(reach, length(box.corner(c) - p));
    const float grow = reach * std::tan(sampling_.half_angle) + length(sat_->cell_size());
    Box3 wide = box;
    wide.lo = wide.lo - Vec3{grow, grow, grow};
    wide.hi = wide.hi + Vec3{grow, grow, grow};
    float t0, t1;
    if (!wide.clip(ray, t0, t1, 0, distance)) return 1.0f;
  }
  return static_cast<float>(std::exp(-cone_optical_depth(*sat_, p, to_light, distance, sampling_)));
}

void SatConeShadows::build(const ShadowCasters& medium, const Light& light) {
  medium_ = &medium;
  sat_ = &medium.extinction_sat();
  light_ = light;
  epsilon_ = 1e-4f * std::max(sat_->bounds().radius(), 1e-6f);
  cache_ = CellField<float>(*sat_, 1.0f);
  std::optional<ConeStencil> stencil;
  if (light.type == LightType::Directional) stencil.emplace(*sat_, -light.direction, sampling_);
  cache_.fill_near_extinction(*sat_, [&](int i, int j, int k) {
    if (!stencil) return attenuation(sat_->cell_center(i, j, k));
    const Vec3 p = sat_->cell_center(i, j, k);
    if (medium.surface_hit(Ray{p, -light.direction}, epsilon_, kInfinity) < kInfinity) return 0.0f;
    return static_cast<float>(std::exp(-stencil->optical_depth(*sat_, i, j, k)));
  });
}

void SatConeShadows::transmittance(std::span<const Vec3> points, std::span<Rgb> out) const {
  for (std::size_t i = 0; i < points.size(); ++i) {
    float t;
    if (!cache_.try_fetch(points[i], t)) t = attenuation(points[i]);
    out[i] = Rgb(t);
  }
}

Vec3 SatConeShadows::surface_receiver(const Vec3& p, const Vec3& n) const {
  return offset_towards_light(light_, p, n, epsilon_);
}

float sampled_cone_transmittance(const ShadowCasters& medium, const Light& light, const Vec3& p, float half_angle,
                                 int rays) {
  Vec3 to_light;
  float distance;
  light.towards(p, to_light, distance);
  const Frame frame = Frame::from_w(to_light);
  const float cos_max = std::cos(half_angle);
  constexpr float kGoldenAngle = 2.39996323f;
  double depth = 0;
  for (int i = 0; i < rays; ++i) {
    const float u = (static_cast<float>(i) + 0.5f) / static_cast<float>(rays);
    const float cos_t = 1 - u * (1 - cos_max), sin_t = std::sqrt(std::max(0.0f, 1 - cos_t * cos_t));
    const float phi = kGoldenAngle * static_cast<float>(i);
    const Vec3 d = frame.to_world({sin_t * std::cos(phi), sin_t * std::sin(phi), cos_t});
    const float t = medium.transmittance(Ray{p, normalize(d)}, 0, distance).g;
    depth += std::min(kOpaqueDepth, -std::log(std::max(static_cast<double>(t), 1e-300)));
  }
  return static_cast<float>(std::exp(-depth / std::max(1, rays)));
}

void SampledConeShadows::build(const ShadowCasters& medium, const Light& light) {
  medium_ = &medium;
  light_ = light;
  const Box3& b = medium.bounds();
  epsilon_ = 1e-4f * (b.empty() ? 1.0f : std::max(b.radius(), 1e-6f));
}

void SampledConeShadows::transmittance(std::span<const Vec3> points, std::span<Rgb> out) const {
  for (std::size_t i = 0; i < points.size(); ++i)
    out[i] = Rgb(sampled_cone_transmittance(*medium_, light_, points[i], half_angle_, rays_));
}

Vec3 SampledConeShadows::surface_receiver(const Vec3& p, const Vec3& n) const {
  return offset_towards_light(light_, p, n, epsilon_);
}

}  // namespace penumbra
