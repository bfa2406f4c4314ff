// Directional soft shadows and scattering from the extinction SAT (paper 001, §2.3 and §3.3): for every
// cell of the light cache, the light's attenuation exp(−Σ_q h·Σ_{q} τ·Δt) over the cuboids q that
// approximate a cone towards the light (cone_cuboids.h), stored once per light and read by the ray
// caster with one trilinear fetch per sample. Receivers outside the cache (planes) evaluate their cone
// directly. Works for directional, point and spot lights anywhere, inside the volume too: the cone
// stops at the light. Opaque planes between a receiver and the light block it (a hard ray test).
//
// | parameter            | default | meaning                                                           |
// | shadows.cone_angle   | 5       | half-angle of the cone towards the light, degrees (§3.3)          |
// | shadows.cone_samples | 50      | cuboids per longest side of the light cache, before growth        |
// | shadows.cone_growth  | 0       | relative growth of each cuboid's thickness over the previous one  |
// | shadows.cone_rays    | 64      | sampled_cone (the reference): exact shadow rays over the cone     |
// | light_cache.resolution | 128   | cells of the SAT and the cache along the volume's longest side    |
#pragma once

#include "penumbra/accel/cell_field.h"
#include "penumbra/scene/scene.h"
#include "penumbra/shadows/cone_cuboids.h"
#include "penumbra/lighting/shadow_technique.h"
#include "penumbra/lighting/technique_info.h"

namespace penumbra {

const TechniqueInfo& sat_cone_technique();
const TechniqueInfo& sampled_cone_technique();

class SatConeShadows final : public ShadowTechnique {
public:
  using ShadowTechnique::transmittance;
  explicit SatConeShadows(const TechniqueParams& params);
  void build(const ShadowCasters& medium, const Light& light) override;
  void transmittance(std::span<const Vec3> points, std::span<Rgb> out) const override;
  Vec3 surface_receiver(const Vec3& p, const Vec3& n) const override;
  std::size_t memory_bytes() const override { return cache_.memory_bytes(); }
  std::string_view name() const override { return "sat_cone"; }
  bool reads_whole_volume() const override { return false; }  // the SAT only

  // The attenuation at p computed from the SAT (what the cache stores at cell centres).
  float attenuation(const Vec3& p) const;
  const ConeSampling& sampling() const { return sampling_; }
  // The attenuation at the cell centres near extinction (what the renderer packs into its LightCache).
  const CellField<float>& cache() const { return cache_; }

private:
  ConeSampling sampling_;
  const ShadowCasters* medium_ = nullptr;
  const ExtinctionSat* sat_ = nullptr;
  Light light_;
  CellField<float> cache_;
  float epsilon_ = 1e-4f;
};

// The densely sampled cone, reference of sat_cone: `rays` exact shadow rays (ShadowCasters::transmittance,
// full data resolution) spread evenly over the cone's solid angle (a golden-angle spiral on the cap of
// half-angle `half_angle` about the direction to the light), each running as far as the light.
// Returns exp(−mean optical depth) — the quantity the cuboids approximate (paper Eq. 7 with h the mean
// over the cone's cross-section); a ray blocked by a plane or below 10⁻⁴ counts as depth 9.21.
float sampled_cone_transmittance(const ShadowCasters& medium, const Light& light, const Vec3& p, float half_angle,
                                 int rays);

// `shadows.technique = sampled_cone`: sampled_cone_transmittance at every receiver (nothing cached; the
// cost of `cone_rays` ray_traced queries).
class SampledConeShadows final : public ShadowTechnique {
public:
  using ShadowTechnique::transmittance;
  explicit SampledConeShadows(const TechniqueParams& params);
  void build(const ShadowCasters& medium, const Light& light) override;
  void transmittance(std::span<const Vec3> points, std::span<Rgb> out) const override;
  Vec3 surface_receiver(const Vec3& p, const Vec3& n) const override;
  std::size_t memory_bytes() const override { return 0; }
  std::string_view name() const override { return "sampled_cone"; }

private:
  float half_angle_;
  int rays_;
  const ShadowCasters* medium_ = nullptr;
  Light light_;
  float epsilon_ = 1e-4f;
};

}  // namespace penumbra
