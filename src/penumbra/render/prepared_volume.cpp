#include "penumbra/render/prepared_volume.h"

#include <algorithm>
#include <cmath>

#include "penumbra/core/parallel.h"

namespace penumbra {
namespace {

// [-1, 1] -> [-127, 127], rounded to nearest
std::int8_t quantise(float x) { return static_cast<std::int8_t>(x * 127.0f + (x >= 0 ? 0.5f : -0.5f)); }

std::vector<std::array<std::int8_t, 4>> gradient_volume(const Volume& vol, float weight_scale) {
  const auto& d = vol.dims();
  std::vector<std::array<std::int8_t, 4>> g(vol.voxel_count());
  const Vec3 inv2{0.5f / vol.spacing().x, 0.5f / vol.spacing().y, 0.5f / vol.spacing().z};
  parallel_for(static_cast<std::size_t>(d[2]), [&](std::size_t k0, std::size_t k1) {
    for (int k = static_cast<int>(k0); k < static_cast<int>(k1); ++k)
      for (int j = 0; j < d[1]; ++j)
        for (int i = 0; i < d[0]; ++i) {
          // central differences, one-sided (and halved accordingly) at the border
          auto diff = [&](int a, int lo_i, int hi_i, int lo_j, int hi_j, int lo_k, int hi_k) {
            const float span = static_cast<float>(a == 0 ? (hi_i - lo_i) : a == 1 ? (hi_j - lo_j) : (hi_k - lo_k)) * 0.5f;
            return span > 0 ? (vol.value(hi_i, hi_j, hi_k) - vol.value(lo_i, lo_j, lo_k)) / span : 0.0f;
          };
          const Vec3 grad{diff(0, std::max(i - 1, 0), std::min(i + 1, d[0] - 1), j, j, k, k) * inv2.x,
                          diff(1, i, i, std::max(j - 1, 0), std::min(j + 1, d[1] - 1), k, k) * inv2.y,
                          diff(2, i, i, j, j, std::max(k - 1, 0), std::min(k + 1, d[2] - 1)) * inv2.z};
          const float len = length(grad);
          const Vec3 n = len > 0 ? grad / len : Vec3{0, 0, 0};
          const float w = std::min(1.0f, len * weight_scale);
          g[vol.index(i, j, k)] = {quantise(n.x), quantise(n.y), quantise(n.z), quantise(w)};
        }
  });
  return g;
}

}  // namespace

PreparedVolume::PreparedVolume(const VolumeObject& o, float step_world) : object(&o), volume(o.volume.get()) {
  update_gradients();
  update_grid();
  update_lut(step_world);
  update_empty();
}

void PreparedVolume::update_gradients() {
  volume = object->volume.get();
  gradients = gradient_volume(*volume, object->reference_step() / std::max(volume->max_value() - volume->min_value(), 1e-20f) /
                                           kFullShadingGradient);
}

void PreparedVolume::update_grid() {
  volume = object->volume.get();
  grid = MacrocellGrid(*volume);
}

void PreparedVolume::update_lut(float step_world) {
  full_step = step_world;
  preview_step = std::max(step_world, std::min(2 * step_world, 8 * object->reference_step()));
  auto table = [&](float s) {
    return TransferLut(object->transfer_function, volume->min_value(), volume->max_value(), s / object->reference_step(), 4096,
                       object->compositing);
  };
  full_lut = table(full_step);
  preview_lut = preview_step == full_step ? full_lut : table(preview_step);
  use(false);
}

void PreparedVolume::use(bool preview) {
  step = preview ? preview_step : full_step;
  lut = preview ? preview_lut : full_lut;
}

void PreparedVolume::update_empty() { empty = grid.empty_cells(lut); }

void PreparedVolume::normal_at(const TrilinearCell& cell, Vec3& direction, float& weight) const {
  float acc[4] = {0, 0, 0, 0};
  const std::size_t offs[8] = {0, cell.sx, cell.sy, cell.sx + cell.sy, cell.sz, cell.sz + cell.sx, cell.sz + cell.sy,
                               cell.sz + cell.sx + cell.sy};
  const float wx[2] = {1 - cell.tx, cell.tx}, wy[2] = {1 - cell.ty, cell.ty}, wz[2] = {1 - cell.tz, cell.tz};
  for (int c = 0; c < 8; ++c) {
    const float w = wx[c & 1] * wy[(c >> 1) & 1] * wz[(c >> 2) & 1];
    const auto& g = gradients[cell.base + offs[c]];
    for (int a = 0; a < 4; ++a) acc[a] += w * static_cast<float>(g[a]);
  }
  direction = {acc[0], acc[1], acc[2]};
  weight = acc[3] * (1.0f / 127.0f);
}

}  // namespace penumbra
