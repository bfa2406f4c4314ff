// Local ambient occlusion and colour bleeding of a volume (paper 001, §2.2, Eqs. 4 and 5):
//   I_AO(s) = I_A · exp(−(1/4π) ∫_N(s) τ_λ(t) / |s − t|² dt),   τ_λ = τ − β·τ·c_λ.
// The integral over the neighbourhood N(s) of radius R is, per direction, the optical depth out to R;
// we divide by the solid angle 4π (the paper folds it into I_A) so that the exponent is that optical
// depth averaged over all directions. β = ambient.bleeding: 0 gives grey occlusion (Eq. 4); 1 lets a
// material pass its own colour c (the DESIGN.md transmission colour), which tints its neighbours
// (Eq. 5, with C_RGB read as 1 − β·c: a red wall passes red light and bleeds red).
//
// Two ways to evaluate the exponent, both on the extinction SAT's cells and stored per cell in a light
// cache read with one trilinear fetch (points outside the cache, on planes, are evaluated directly):
//   sat_shells — the paper's cuboid shells (§3.2): n cubes of half-sizes h_1 < … < h_n cells around the
//                cell, shell i weighted by 1 / r_i² (r_i = (h_i + ½) cells, centre to face):
//                x = (V_cell/4π)·[S(Sh_1)/r_1² + Σ_i (S(Sh_i) − S(Sh_{i−1}))/r_i²], 8 lookups a shell;
//   sampled_ao — the reference: every cell of the ball of radius R weighted by V_cell/(4π|s − t|²)
//                (the cell's own contribution by the exact integral of 1/r² over a cube), the paper's
//                "sampled radius" column.
//
// | parameter              | default | meaning                                                        |
// | ambient.shells         | 3       | sat_shells: number of cuboid shells n                          |
// | ambient.radius         | 0.05    | R, a fraction of the volume's longest side                     |
// | ambient.bleeding       | 0       | β: 0 grey occlusion (Eq. 4), 1 full colour bleeding (Eq. 5)    |
// | light_cache.resolution | 128     | cells of the SAT and the cache along the longest side          |
#pragma once

#include <vector>

#include "penumbra/accel/cell_field.h"
#include "penumbra/scene/scene.h"
#include "penumbra/lighting/ambient_technique.h"
#include "penumbra/lighting/technique_info.h"

namespace penumbra {

const TechniqueInfo& sat_shells_technique();
const TechniqueInfo& sampled_ao_technique();

// ∫ 1/|x|² dx over the unit cube centred at the origin (6·∫_face ½ / (¼ + x² + y²)).
constexpr double kUnitCubeInverseSquare = 7.674124606715782;

// Half-sizes (cells) of the n cuboid shells for a radius of `radius_cells`: h_i ≈ radius·i/n, strictly
// increasing, at least 1.
std::vector<int> shell_half_sizes(int shells, float radius_cells);

class VolumeAmbientOcclusion : public AmbientTechnique {
public:
  using AmbientTechnique::ambient;
  void build(const ShadowCasters& medium) override;
  bool reads_whole_volume() const override { return false; }  // the SAT only
  void ambient(std::span<const Vec3> points, std::span<Rgb> out) const override;
  std::size_t memory_bytes() const override { return cache_.memory_bytes(); }

  // The exponent's three channels for the cell (i, j, k) (may lie outside the grid).
  virtual Rgb optical_depth(int i, int j, int k) const = 0;
  // The ambient term at the cell centres near extinction (what the renderer packs into its LightCache).
  const CellField<Rgb>& cache() const { return cache_; }

protected:
  explicit VolumeAmbientOcclusion(const TechniqueParams& params);
  virtual void prepare() {}  // after sat_ is set, before the cache is filled
  float radius_cells() const;

  float radius_;    // a fraction of the volume's longest side
  float bleeding_;  // β
  int shells_;      // sat_shells only
  const ExtinctionSat* sat_ = nullptr;

private:
  Rgb ambient_at_cell(int i, int j, int k) const;
  CellField<Rgb> cache_;
};

class SatShellsAmbient final : public VolumeAmbientOcclusion {
public:
  explicit SatShellsAmbient(const TechniqueParams& params) : VolumeAmbientOcclusion(params) {}
  Rgb optical_depth(int i, int j, int k) const override;
  std::string_view name() const override { return "sat_shells"; }

private:
  void prepare() override;
  std::vector<int> half_sizes_;
  std::vector<double> weights_;  // V_cell / (4π r_i²)
};

class SampledAmbientOcclusion final : public VolumeAmbientOcclusion {
public:
  explicit SampledAmbientOcclusion(const TechniqueParams& params) : VolumeAmbientOcclusion(params) {}
  Rgb optical_depth(int i, int j, int k) const override;
  std::string_view name() const override { return "sampled_ao"; }

private:
  void prepare() override;
  struct Offset {
    int di, dj, dk;
    double weight;  // V_cell / (4π |offset|²), or the cell's own integral
  };
  std::vector<Offset> offsets_;
};

}  // namespace penumbra
