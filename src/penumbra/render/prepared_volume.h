// The visible volume made ready for the ray caster: its transfer function tabulated for the eye step,
// its macrocell grid (shared with the shadow medium), the cells that grid marks empty, and a gradient
// volume: central differences at every voxel (world units), stored as a quantised unit normal plus a
// shading weight, 4 bytes a voxel, so that a shaded sample costs one 4-channel trilinear fetch instead
// of six scalar ones per corner. Where that memory is not wanted (volumes[].gradients = on_the_fly, or
// auto beyond kStoredGradientBytes) the eight corners' gradients are computed per shaded sample with
// the same arithmetic: the same frame, more time, no memory.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "penumbra/accel/macrocell_grid.h"
#include "penumbra/data/transfer_function.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

// |∇v| (as a fraction of the data range per voxel) at and above which a sample is fully
// gradient-shaded; flatter samples fade to unshaded (pure emission under the light), as their normal
// is noise. Keeps homogeneous interiors from speckling.
constexpr float kFullShadingGradient = 0.03f;

// Each part can be rebuilt in place (the renderer does so after an edit): the gradients and the min/max
// grid depend only on the data, the table on the transfer function and the step, the empty cells on
// the transfer function.
struct PreparedVolume {
  // `step_world`: the eye's sampling step (the object's own; the finest of them where volumes overlap).
  explicit PreparedVolume(const VolumeObject& o) : PreparedVolume(o, o.step_world()) {}
  PreparedVolume(const VolumeObject& o, float step_world);

  void update_gradients();
  void update_grid();
  // The object's transfer function tabulated for this step and for a preview's (twice as long, at
  // most 8 voxels); use() picks one.
  void update_lut(float step_world);
  void use(bool preview);
  void update_empty();                // the cells the table makes invisible

  // Interpolated gradient direction (world space, not normalised) and shading weight in [0, 1] at
  // continuous voxel coordinates v (inside the grid).
  void normal_at(const Vec3& v, Vec3& direction, float& weight) const { normal_at(volume->trilinear_cell(v), direction, weight); }
  void normal_at(const TrilinearCell& cell, Vec3& direction, float& weight) const;  // the cell the sample's value came from

  std::size_t memory_bytes() const { return gradient_bytes() + grid.memory_bytes() + empty.size(); }
  std::size_t gradient_bytes() const { return gradients.size() * sizeof(gradients[0]); }
  bool gradients_stored() const { return !gradients_on_the_fly; }

  // The part [t0, t1] of r within [tmin, tmax] inside the volume's box and kept by its clip planes.
  bool span(const Ray& r, float& t0, float& t1, float tmin, float tmax) const {
    return volume->bounds().clip(r, t0, t1, tmin, tmax) && (!clip || clip->keep(r, t0, t1));
  }

  const VolumeObject* object;
  const Volume* volume;
  const ClipPlanes* clip = nullptr;  // the scene's clip planes that cut this volume (set every frame); null: none
  float step;  // world units: the step in use
  TransferLut lut;  // the table in use
  float full_step = 0, preview_step = 0;
  TransferLut full_lut, preview_lut;
  MacrocellGrid grid;
  std::vector<std::uint8_t> empty;
  std::vector<std::array<std::int8_t, 4>> gradients;  // (nx, ny, nz) · 127, weight · 127; empty when on the fly
  bool gradients_on_the_fly = false;
  float gradient_weight_scale = 0;  // |∇v| (world units) to shading weight

private:
  void normal_on_the_fly(const TrilinearCell& cell, Vec3& direction, float& weight) const;
};

}  // namespace penumbra
