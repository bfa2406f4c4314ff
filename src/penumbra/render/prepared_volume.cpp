#include "penumbra/render/prepared_volume.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#if defined(__SSE2__)
#include <emmintrin.h>
#endif

#include "penumbra/core/parallel.h"

namespace penumbra {
namespace {

// [-1, 1] -> [-127, 127], rounded to nearest
std::int8_t quantise(float x) { return static_cast<std::int8_t>(x * 127.0f + (x >= 0 ? 0.5f : -0.5f)); }

// The quantised unit normal of a gradient and its shading weight.
std::array<std::int8_t, 4> quantised_gradient(const Vec3& grad, float weight_scale) {
  const float len = length(grad);
  const Vec3 n = len > 0 ? grad / len : Vec3{0, 0, 0};
  const float w = std::min(1.0f, len * weight_scale);
  return {quantise(n.x), quantise(n.y), quantise(n.z), quantise(w)};
}

// The quantised normal and shading weight at voxel (i, j, k): central differences, one-sided (and halved
// accordingly) at the border.
std::array<std::int8_t, 4> voxel_gradient(const Volume& vol, int i, int j, int k, const Vec3& inv2, float weight_scale) {
  const auto& d = vol.dims();
  auto diff = [&](int a, int lo_i, int hi_i, int lo_j, int hi_j, int lo_k, int hi_k) {
    const float span = static_cast<float>(a == 0 ? (hi_i - lo_i) : a == 1 ? (hi_j - lo_j) : (hi_k - lo_k)) * 0.5f;
    return span > 0 ? (vol.value(hi_i, hi_j, hi_k) - vol.value(lo_i, lo_j, lo_k)) / span : 0.0f;
  };
  const Vec3 grad{diff(0, std::max(i - 1, 0), std::min(i + 1, d[0] - 1), j, j, k, k) * inv2.x,
                  diff(1, i, i, std::max(j - 1, 0), std::min(j + 1, d[1] - 1), k, k) * inv2.y,
                  diff(2, i, i, j, j, std::max(k - 1, 0), std::min(k + 1, d[2] - 1)) * inv2.z};
  return quantised_gradient(grad, weight_scale);
}

// A dense volume's gradients, row by row: interior voxels read their six neighbours straight from the
// voxels of type T (the arithmetic of voxel_gradient, whose span is 1 there), border voxels go through
// voxel_gradient.
template <class T>
void dense_gradients(const Volume& vol, const Vec3& inv2, float weight_scale, std::vector<std::array<std::int8_t, 4>>& g) {
  const auto& d = vol.dims();
  const T* v = vol.data_as<T>();
  const std::size_t sy = static_cast<std::size_t>(d[0]), sz = sy * static_cast<std::size_t>(d[1]);
  parallel_for(static_cast<std::size_t>(d[2]), [&](std::size_t k0, std::size_t k1) {
    for (int k = static_cast<int>(k0); k < static_cast<int>(k1); ++k)
      for (int j = 0; j < d[1]; ++j) {
        const std::size_t row = static_cast<std::size_t>(k) * sz + static_cast<std::size_t>(j) * sy;
        const bool inner_row = j > 0 && j < d[1] - 1 && k > 0 && k < d[2] - 1;
        for (int i = 0; i < d[0]; ++i) {
          const std::size_t at = row + static_cast<std::size_t>(i);
          if (!inner_row || i == 0 || i == d[0] - 1) {
            g[at] = voxel_gradient(vol, i, j, k, inv2, weight_scale);
            continue;
          }
          const Vec3 grad{(static_cast<float>(v[at + 1]) - static_cast<float>(v[at - 1])) * inv2.x,
                          (static_cast<float>(v[at + sy]) - static_cast<float>(v[at - sy])) * inv2.y,
                          (static_cast<float>(v[at + sz]) - static_cast<float>(v[at - sz])) * inv2.z};
          g[at] = quantised_gradient(grad, weight_scale);
        }
      }
  });
}

// One gradient per stored voxel, in the volume's layout. A bricked volume's shared bricks are flat
// (their voxels and the ones beyond hold one value), so their gradient is zero; the other bricks' 9³
// voxels are each computed, their clamped copies past the grid's end included.
std::vector<std::array<std::int8_t, 4>> gradient_volume(const Volume& vol, float weight_scale) {
  const auto& d = vol.dims();
  std::vector<std::array<std::int8_t, 4>> g(vol.stored_voxel_count());
  const Vec3 inv2{0.5f / vol.spacing().x, 0.5f / vol.spacing().y, 0.5f / vol.spacing().z};
  if (vol.is_bricked()) {
    const auto& bricks = vol.brick_grid();
    parallel_for(static_cast<std::size_t>(bricks[2]) * bricks[1], [&](std::size_t r0, std::size_t r1) {
      for (std::size_t r = r0; r < r1; ++r) {
        const int bz = static_cast<int>(r / static_cast<std::size_t>(bricks[1])), by = static_cast<int>(r % static_cast<std::size_t>(bricks[1]));
        for (int bx = 0; bx < bricks[0]; ++bx) {
          const std::size_t base = vol.brick_base(bx, by, bz);
          if (vol.brick_is_shared(bx, by, bz)) {
            std::fill(g.begin() + static_cast<std::ptrdiff_t>(base), g.begin() + static_cast<std::ptrdiff_t>(base + Volume::kBrickVoxels),
                      std::array<std::int8_t, 4>{0, 0, 0, 0});
            continue;
          }
          constexpr int n = Volume::kBrickSide, c = Volume::kBrickCells;
          for (int z = 0; z < n; ++z)
            for (int y = 0; y < n; ++y)
              for (int x = 0; x < n; ++x)
                g[base + (static_cast<std::size_t>(z) * n + y) * n + x] =
                    voxel_gradient(vol, std::min(bx * c + x, d[0] - 1), std::min(by * c + y, d[1] - 1),
                                   std::min(bz * c + z, d[2] - 1), inv2, weight_scale);
        }
      }
    });
    return g;
  }
  vol.with_voxel_type([&](auto type) { dense_gradients<decltype(type)>(vol, inv2, weight_scale, g); });
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
  gradient_weight_scale = object->reference_step() / std::max(volume->max_value() - volume->min_value(), 1e-20f) / kFullShadingGradient;
  const std::size_t stored_bytes = volume->stored_voxel_count() * sizeof(gradients[0]);
  gradients_on_the_fly = object->gradients == VolumeObject::Gradients::OnTheFly ||
                         (object->gradients == VolumeObject::Gradients::Auto && stored_bytes > kStoredGradientBytes);
  gradients.clear();
  gradients.shrink_to_fit();  // an edit to on_the_fly gives the memory back
  if (!gradients_on_the_fly) gradients = gradient_volume(*volume, gradient_weight_scale);
}

void PreparedVolume::update_grid() {
  volume = object->volume.get();
  grid = MacrocellGrid(*volume);
}

void PreparedVolume::update_lut(float step_world) {
  full_step = step_world;
  preview_step = std::max(step_world, std::min(2 * step_world, 8 * object->voxel_step()));
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

// The stored path's arithmetic on the cell's eight corners, each gradient computed from the voxels
// (voxel_gradient, quantised as stored), so that both paths give the same bits.
void PreparedVolume::normal_on_the_fly(const TrilinearCell& cell, Vec3& direction, float& weight) const {
  const auto& d = volume->dims();
  const Vec3 inv2{0.5f / volume->spacing().x, 0.5f / volume->spacing().y, 0.5f / volume->spacing().z};
  const float wx[2] = {1 - cell.tx, cell.tx}, wy[2] = {1 - cell.ty, cell.ty}, wz[2] = {1 - cell.tz, cell.tz};
  float acc[4] = {0, 0, 0, 0};
  // A cell whose corners' neighbours all lie in a dense grid (most cells): the 32 voxels read straight
  // from the typed voxels, with dense_gradients' arithmetic (voxel_gradient's, whose span is 1 there).
  if (!volume->is_bricked() && !volume->is_window() && cell.i >= 1 && cell.j >= 1 && cell.k >= 1 && cell.i + 2 < d[0] &&
      cell.j + 2 < d[1] && cell.k + 2 < d[2]) {
    const std::size_t sy = static_cast<std::size_t>(d[0]), sz = sy * static_cast<std::size_t>(d[1]);
    volume->with_voxel_type([&](auto type) {
      using T = decltype(type);
      const T* v = volume->data_as<T>();
      for (int c = 0; c < 8; ++c) {
        const std::size_t at = cell.base + (c & 1 ? 1 : 0) + (c & 2 ? sy : 0) + (c & 4 ? sz : 0);
        const Vec3 grad{(static_cast<float>(v[at + 1]) - static_cast<float>(v[at - 1])) * inv2.x,
                        (static_cast<float>(v[at + sy]) - static_cast<float>(v[at - sy])) * inv2.y,
                        (static_cast<float>(v[at + sz]) - static_cast<float>(v[at - sz])) * inv2.z};
        const auto g = quantised_gradient(grad, gradient_weight_scale);
        const float w = wx[c & 1] * wy[(c >> 1) & 1] * wz[(c >> 2) & 1];
        for (int a = 0; a < 4; ++a) acc[a] += w * static_cast<float>(g[a]);
      }
    });
    direction = {acc[0], acc[1], acc[2]};
    weight = acc[3] * (1.0f / 127.0f);
    return;
  }
  const int i1 = std::min(cell.i + 1, d[0] - 1), j1 = std::min(cell.j + 1, d[1] - 1), k1 = std::min(cell.k + 1, d[2] - 1);
  for (int c = 0; c < 8; ++c) {
    const float w = wx[c & 1] * wy[(c >> 1) & 1] * wz[(c >> 2) & 1];
    const auto g = voxel_gradient(*volume, c & 1 ? i1 : cell.i, c & 2 ? j1 : cell.j, c & 4 ? k1 : cell.k, inv2, gradient_weight_scale);
    for (int a = 0; a < 4; ++a) acc[a] += w * static_cast<float>(g[a]);
  }
  direction = {acc[0], acc[1], acc[2]};
  weight = acc[3] * (1.0f / 127.0f);
}

void PreparedVolume::normal_at(const TrilinearCell& cell, Vec3& direction, float& weight) const {
  if (gradients_on_the_fly) return normal_on_the_fly(cell, direction, weight);
  float acc[4] = {0, 0, 0, 0};
  const std::size_t offs[8] = {0, cell.sx, cell.sy, cell.sx + cell.sy, cell.sz, cell.sz + cell.sx, cell.sz + cell.sy,
                               cell.sz + cell.sx + cell.sy};
  const float wx[2] = {1 - cell.tx, cell.tx}, wy[2] = {1 - cell.ty, cell.ty}, wz[2] = {1 - cell.tz, cell.tz};
#if defined(__SSE2__)
  // the four signed bytes of a corner widened and converted in one register: the same products and sums
  // per component as the loop below, a quarter of the instructions
  __m128 sum = _mm_setzero_ps();
  for (int c = 0; c < 8; ++c) {
    const float w = wx[c & 1] * wy[(c >> 1) & 1] * wz[(c >> 2) & 1];
    std::int32_t packed;
    std::memcpy(&packed, gradients[cell.base + offs[c]].data(), sizeof packed);
    __m128i g = _mm_cvtsi32_si128(packed);
    g = _mm_unpacklo_epi8(g, g);   // each byte in the top of its 32-bit lane …
    g = _mm_unpacklo_epi16(g, g);
    g = _mm_srai_epi32(g, 24);     // … shifted down with its sign
    sum = _mm_add_ps(sum, _mm_mul_ps(_mm_set1_ps(w), _mm_cvtepi32_ps(g)));
  }
  _mm_storeu_ps(acc, sum);
#else
  for (int c = 0; c < 8; ++c) {
    const float w = wx[c & 1] * wy[(c >> 1) & 1] * wz[(c >> 2) & 1];
    const auto& g = gradients[cell.base + offs[c]];
    for (int a = 0; a < 4; ++a) acc[a] += w * static_cast<float>(g[a]);
  }
#endif
  direction = {acc[0], acc[1], acc[2]};
  weight = acc[3] * (1.0f / 127.0f);
}

}  // namespace penumbra
