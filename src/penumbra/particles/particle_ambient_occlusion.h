// Object-space ambient occlusion for particles after Staib, Grottel and Gumhold, "Visualization of
// Particle-based Data with Transparency and Ambient Occlusion" (CGF 34(3), 2015), the AO that paper 003
// combines with ISSM. Build: the spheres are splatted into a volume of filled fractions ρ (a sphere
// smaller than a cell spreads its volume trilinearly over the 8 cells around its centre; a larger one
// fills each cell by how far the cell's centre is inside it, a ramp one cell wide; sums clamped to 1),
// turned into the opacity of one cell, and a pyramid of opacities composed 2×2×2 (a parent's opacity
// is 1 − the mean transmittance of the two-child columns along the three axes). Query: `directions`
// cones (half-angle θ with 1 − cos θ = 1/directions, so that `directions` of them tile a hemisphere;
// a fixed set of 2·directions covers the sphere and each point uses those in its hemisphere) march
// outwards — from the sphere's surface point in the cone's direction, so that all the pixels of a
// sphere share its cones, kept across frames — each step half the cone's diameter, sampling the
// level whose cell matches the diameter (trilinear, blended between levels) and compositing its
// opacity front to back, up to `max_distance`. The ambient factor is 1 minus the cosine-weighted mean
// of the cones' occlusion. Our choices are explained and measured in docs/techniques/issm.md. Moving
// atoms (a trajectory's next frame), paper 003's "updated, not rebuilt, when atoms move a little": with
// `reuse` > 0 a rebuild keeps each sphere's traced cones while the sphere has moved (centre and radius)
// less than `reuse` density cells since they were traced. The density grid stays where the kept cones
// were traced while it holds the occluders and a fresh grid would lie within `reuse` cells of it. All
// the cones are dropped when matter has moved more than that anywhere: some cell's filled fraction (the
// one its opacity stands for, volumes included) changed by more than `reuse` since the cones were first
// kept (an edge of matter shifted by δ cells changes it by about δ), or the grid had to move. A frame
// then depends on the frames built before it; `reuse` 0 (the default) traces every cone anew at every
// build. A particle scene split by space over MPI ranks (accel/brick_reduction.h) splats each rank's spheres
// into a grid over all of them and sums the ranks' densities (one allreduce of a double a cell); beside
// a volume split into slabs, each rank composes the volume's opacity into the cells whose centres its
// slab owns (it holds only its brick's voxels) and the ranks add the cells (one allreduce likewise).
//
// | parameter            | default | meaning                                               |
// | ambient.directions   | 16      | cones per hemisphere                                  |
// | ambient.max_distance | 0.7     | reach, a fraction of the spheres' longest side         |
// | ambient.grid         | 64      | density-volume cells along the spheres' longest side   |
// | ambient.reuse        | 0       | cells atoms may move before their cones are traced anew |
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/particles/sphere_cone_cache.h"
#include "penumbra/scene/scene.h"
#include "penumbra/lighting/ambient_technique.h"
#include "penumbra/lighting/technique_info.h"

namespace penumbra {

// Occluders of every kind it takes (spheres and volumes): the volumes' opacity across a cell (their
// shadow transfer functions sampled at the cell centres) is composed into the base level with the
// spheres'. A volume sample (no normal) averages the cones of the whole sphere of directions.
const TechniqueInfo& particle_ao_technique();

class ParticleAmbientOcclusion final : public AmbientTechnique {
public:
  static constexpr std::size_t kMaxCacheBytes = std::size_t{512} << 20;  // the cone cache's budget

  explicit ParticleAmbientOcclusion(const TechniqueParams& params, std::size_t cone_cache_bytes = kMaxCacheBytes);
  void build(const ShadowCasters& occluders) override;
  void ambient(std::span<const Vec3> points, std::span<Rgb> out) const override;
  void ambient(std::span<const SurfacePoint> points, std::span<Rgb> out) const override;
  std::size_t memory_bytes() const override;
  std::string_view name() const override { return "particle_ao"; }
  // Split over bricks: the volumes' opacity composed per cell by the brick owning the cell's centre,
  // the split spheres' densities added (accel/brick_reduction.h).
  bool combines_over_bricks() const override { return true; }
  bool reads_whole_volume() const override { return false; }
  bool keeps_state_across_builds() const override { return reuse_ > 0; }
  std::size_t kept_from_last_build() const override { return spheres_kept_; }  // spheres whose cones were kept

  // Density (filled fraction) of level `level` at world point p, trilinear; 0 outside the grid.
  float density(int level, const Vec3& p) const;
  // The ambient factor at a volume sample p, from every cone of the sphere of directions, uncached:
  // what the lattice below holds at its corners, and what points outside the lattice get.
  float volume_point_ambient(const Vec3& p) const;
  int levels() const { return static_cast<int>(pyramid_.size()); }

private:
  struct Level {
    int nx = 0, ny = 0, nz = 0;
    float cell = 0;  // world edge length of a cell
    std::vector<float> value;
    float at(int x, int y, int z) const {
      if (x < 0 || y < 0 || z < 0 || x >= nx || y >= ny || z >= nz) return 0;
      return value[(static_cast<std::size_t>(z) * static_cast<std::size_t>(ny) + static_cast<std::size_t>(y)) * static_cast<std::size_t>(nx) + static_cast<std::size_t>(x)];
    }
  };
  // Occlusion along one cone from `origin`, ignoring the steps nearer than `skip`.
  float occlusion(const Vec3& origin, const Vec3& dir, float skip) const;
  float sphere_cone(std::uint32_t sphere, std::size_t cone) const;  // quantised to 1/255, cached (cone_cache_)
  void keep_or_reset_cones(const ParticleSet& ps);  // build's last step: ambient.reuse

  int directions_;
  float max_distance_fraction_;
  int grid_;
  float reuse_;  // cells (ambient.reuse)
  std::size_t cone_cache_bytes_;
  Vec3 origin_;  // world position of the grid's lower corner
  std::vector<Level> pyramid_;
  float max_distance_ = 1;
  float tan_half_ = 0.5f;
  struct ConeStep {
    float distance;  // from the cone's apex
    int level;       // pyramid level sampled
    float blend;     // weight of level + 1
    float reach;     // how far past the fine grid's box the levels sampled hold density
  };
  std::vector<ConeStep> steps_;
  Box3 grid_box_;
  std::vector<Vec3> cone_dirs_;  // world directions over the whole sphere
  std::vector<float> cone_x_, cone_y_, cone_z_;  // the same by component, zero-padded to a multiple of 4
  const ParticleSet* particles_ = nullptr;
  SphereConeCache cone_cache_;
  // ambient.reuse: each sphere as its kept cones were traced; each base cell's filled fraction now and
  // when the cones were first kept (kept_base_: that grid)
  std::vector<Sphere> traced_as_;
  std::vector<float> filled_;
  Level kept_base_;
  Vec3 kept_origin_;
  std::size_t spheres_kept_ = 0;
  // Volume samples' ambient factor on the corners of the base level's cells, filled as samples first
  // need them and kept until the next build: it does not depend on the camera, so an orbit reuses it
  // (a volume sample costs 2·directions cone marches uncached; a 64-cell grid has 65³ corners against
  // tens of millions of samples a frame). A sample interpolates its cell's eight corners. Each corner
  // holds a float's bits, or kUnfilled; threads that fill the same corner store the same value.
  static constexpr std::uint32_t kUnfilled = 0xFFFFFFFFu;
  float corner_ambient(int x, int y, int z) const;
  int corners_x_ = 0, corners_y_ = 0, corners_z_ = 0;
  std::unique_ptr<std::atomic<std::uint32_t>[]> volume_ambient_;
};

}  // namespace penumbra
