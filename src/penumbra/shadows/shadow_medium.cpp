#include "penumbra/shadows/shadow_medium.h"

#include "penumbra/core/error.h"

namespace penumbra {

ShadowMedium::ShadowMedium(const Scene& scene, const MacrocellGrid& grid)
    : planes_(&scene.planes), bounds_(scene.caster_bounds()), grid_(&grid) {
  const VolumeObject* v = scene.visible_volume();
  if (!v) return;
  volume_ = v->volume.get();
  volume_box_ = volume_->bounds();
  const float steps_in_voxels = scene.shadows.step > 0 ? scene.shadows.step : kDefaultShadowStepVoxels;
  step_ = steps_in_voxels * v->reference_step();
  lut_ = TransferLut(v->shadow_tf(), volume_->min_value(), volume_->max_value(), step_ / v->reference_step(), 4096,
                     v->compositing);
  achromatic_ = v->compositing == Compositing::Extinction;
  empty_ = grid_->empty_cells(lut_);
}

const ExtinctionSat& ShadowMedium::extinction_sat() const {
  if (!sat_) throw Error("the extinction techniques (sat_cone, sat_shells, sampled_ao) need a visible volume");
  return *sat_;
}

}  // namespace penumbra
