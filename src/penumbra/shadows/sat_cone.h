// Directional soft shadows and scattering from the extinction SAT (paper 001, §2.3 and §3.3): for every
// cell of the light cache, the light's attenuation exp(−Σ_q h·Σ_{q} τ·Δt) over the cuboids q that
// approximate a cone towards the light (cone_cuboids.h), stored once per light and read by the ray
// caster with one trilinear fetch per sample. Receivers outside the cache (planes) evaluate their cone
// directly. Works for directional, point and spot lights anywhere, inside the volume too: the cone
// stops at the light. Opaque planes between a receiver and the light block it (a hard ray test).
#pragma once

#include "penumbra/accel/cell_field.h"
#include "penumbra/scene/scene.h"
#include "penumbra/shadows/cone_cuboids.h"
#include "penumbra/shadows/shadow_technique.h"

namespace penumbra {

class SatConeShadows final : public ShadowTechnique {
public:
  using ShadowTechnique::transmittance;
  explicit SatConeShadows(const ShadowSettings& settings);
  void build(const ShadowMedium& medium, const Light& light) override;
  void transmittance(std::span<const Vec3> points, std::span<Rgb> out) const override;
  Vec3 surface_receiver(const Vec3& p, const Vec3& n) const override;
  std::size_t memory_bytes() const override { return cache_.memory_bytes(); }
  std::string_view name() const override { return "sat_cone"; }

  // The attenuation at p computed from the SAT (what the cache stores at cell centres).
  float attenuation(const Vec3& p) const;
  const ConeSampling& sampling() const { return sampling_; }

private:
  ConeSampling sampling_;
  const ShadowMedium* medium_ = nullptr;
  const ExtinctionSat* sat_ = nullptr;
  Light light_;
  CellField<float> cache_;
  float epsilon_ = 1e-4f;
};

}  // namespace penumbra
