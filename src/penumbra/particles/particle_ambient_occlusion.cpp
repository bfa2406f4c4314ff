#include "penumbra/particles/particle_ambient_occlusion.h"

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <span>
#if defined(__SSE__)
#include <xmmintrin.h>  // SSE: the per-pixel cone weighting
#endif

#include "penumbra/core/cutoffs.h"
#include "penumbra/core/parallel.h"
#include "penumbra/lighting/shared_params.h"

namespace penumbra {

namespace {

// The per-pixel cone arithmetic over arrays padded to a multiple of 4, four lanes at a time with SSE
// (lane j takes the values j, j + 4, …; the scalar forms below, for other processors, do the same
// operations in the same order, so both give the same bits).

// w[c] = max(n · d_c, 0) for the directions d_c given by component.
void cone_weights(const Vec3& n, std::span<const float> dx, std::span<const float> dy, std::span<const float> dz, std::span<float> w) {
#if defined(__SSE__)
  const __m128 nx = _mm_set1_ps(n.x), ny = _mm_set1_ps(n.y), nz = _mm_set1_ps(n.z), zero = _mm_setzero_ps();
  for (std::size_t g = 0; g < w.size(); g += 4) {
    const __m128 d = _mm_add_ps(_mm_add_ps(_mm_mul_ps(nx, _mm_loadu_ps(dx.data() + g)), _mm_mul_ps(ny, _mm_loadu_ps(dy.data() + g))),
                                _mm_mul_ps(nz, _mm_loadu_ps(dz.data() + g)));
    _mm_storeu_ps(w.data() + g, _mm_max_ps(d, zero));
  }
#else
  for (std::size_t c = 0; c < w.size(); ++c) w[c] = std::max(n.x * dx[c] + n.y * dy[c] + n.z * dz[c], 0.0f);
#endif
}

// Bit i set where w[i] > 0, for up to 64 values.
std::uint64_t positive_mask(std::span<const float> w) {
  std::uint64_t mask = 0;
#if defined(__SSE__)
  const __m128 zero = _mm_setzero_ps();
  for (std::size_t g = 0; g < w.size(); g += 4)
    mask |= static_cast<std::uint64_t>(_mm_movemask_ps(_mm_cmpgt_ps(_mm_loadu_ps(w.data() + g), zero))) << g;
#else
  for (std::size_t i = 0; i < w.size(); ++i) mask |= static_cast<std::uint64_t>(w[i] > 0) << i;
#endif
  return mask;
}

// 1 − Σ w·a / Σ w (1 where no weight), the sums in four interleaved partial sums (four independent
// chains, one lane each) added pairwise at the end. A zero weight adds exactly nothing, whatever a.
float weighted_clearance(std::span<const float> w, std::span<const float> a) {
  float sum[4], weights[4];
#if defined(__SSE__)
  __m128 s = _mm_setzero_ps(), ws = _mm_setzero_ps();
  for (std::size_t g = 0; g < w.size(); g += 4) {
    const __m128 wg = _mm_loadu_ps(w.data() + g);
    s = _mm_add_ps(s, _mm_mul_ps(wg, _mm_loadu_ps(a.data() + g)));
    ws = _mm_add_ps(ws, wg);
  }
  _mm_storeu_ps(sum, s);
  _mm_storeu_ps(weights, ws);
#else
  std::fill(std::begin(sum), std::end(sum), 0.0f);
  std::fill(std::begin(weights), std::end(weights), 0.0f);
  for (std::size_t g = 0; g < w.size(); g += 4)
    for (std::size_t j = 0; j < 4; ++j) {
      sum[j] += w[g + j] * a[g + j];
      weights[j] += w[g + j];
    }
#endif
  const float total = (sum[0] + sum[1]) + (sum[2] + sum[3]), weight = (weights[0] + weights[1]) + (weights[2] + weights[3]);
  return weight > 0 ? 1.0f - total / weight : 1.0f;
}

}  // namespace

void ParticleAmbientOcclusion::build(const ShadowCasters& occluders) {
  static const ParticleSet kNoSpheres;
  particles_ = occluders.spheres().set ? occluders.spheres().set : &kNoSpheres;
  const ParticleSet& ps = *particles_;
  // spheres split over bricks: their densities add (the spheres' bounds are already every brick's)
  const ShadowBrick* brick = occluders.brick();
  BrickReduction* reduction = brick && brick->own_spheres ? brick->reduction : nullptr;
  // the spheres' and the volumes' box (a pyramid's finest level's too: its cells are those of the
  // finest level in memory, whichever level is opened)
  Box3 b = occluders.bounds();
  for (const auto& cv : occluders.volumes()) b.extend(cv->extent);
  if (b.empty()) b = Box3{{-1, -1, -1}, {1, 1, 1}};
  const Vec3 e = b.extent();
  const float longest = std::max(e.x, std::max(e.y, e.z));
  max_distance_ = max_distance_fraction_ * longest;
  // cubic cells, `grid` along the longest side, one cell of margin so the splat never falls off
  float cell = longest / static_cast<float>(grid_);
  origin_ = b.lo - Vec3{cell, cell, cell};
  Level base;
  base.cell = cell;
  base.nx = static_cast<int>(std::ceil(e.x / cell)) + 2;
  base.ny = static_cast<int>(std::ceil(e.y / cell)) + 2;
  base.nz = static_cast<int>(std::ceil(e.z / cell)) + 2;
  if (reuse_ > 0 && !kept_base_.value.empty()) {
    // ambient.reuse: the grid the kept cones were traced on, while it holds the occluders and lies
    // within `reuse` cells of this one (the cones' samples then fall on the same cells)
    const float kept_cell = kept_base_.cell;
    const Vec3 kept_hi = kept_origin_ + Vec3{static_cast<float>(kept_base_.nx), static_cast<float>(kept_base_.ny), static_cast<float>(kept_base_.nz)} * kept_cell;
    const bool near = length(origin_ - kept_origin_) <= reuse_ * kept_cell && std::abs(cell - kept_cell) * static_cast<float>(grid_) <= reuse_ * kept_cell;
    const Vec3 half{0.5f * kept_cell, 0.5f * kept_cell, 0.5f * kept_cell};  // the splat's reach past a centre
    const Vec3 lo = kept_origin_ + half, hi = kept_hi - half;
    const bool holds = lo.x <= b.lo.x && lo.y <= b.lo.y && lo.z <= b.lo.z && b.hi.x <= hi.x && b.hi.y <= hi.y && b.hi.z <= hi.z;
    if (near && holds) {
      cell = kept_cell;
      origin_ = kept_origin_;
      base.cell = cell;
      base.nx = kept_base_.nx, base.ny = kept_base_.ny, base.nz = kept_base_.nz;
    }
  }
  const std::size_t n = static_cast<std::size_t>(base.nx) * static_cast<std::size_t>(base.ny) * static_cast<std::size_t>(base.nz);
  base.value.assign(n, 0.0f);

  // split spheres: a sphere two bricks hold (across a slab face) counts on the one owning its centre
  const auto counted = [&](const Sphere& sp) { return !reduction || brick->slab.owns(sp.center); };
  double radii[] = {0, 0};  // their sum, and how many
  for (const Sphere& sp : ps.spheres)
    if (counted(sp)) radii[0] += sp.radius, radii[1] += 1;
  if (reduction) reduction->sum(radii);
  const float mean_radius = radii[1] > 0 ? static_cast<float>(radii[0] / radii[1]) : cell;
  const float cell_exponent = 0.75f * cell / mean_radius;

  // The spheres' filled fraction per cell (cell centres at (i + 0.5)·cell), accumulated in a few
  // copies, each from its own range of spheres, then added: the same sum for any thread count.
  const float inv_cell = 1.0f / cell;
  const float inv_cell_volume = inv_cell * inv_cell * inv_cell;
  auto index = [&](int x, int y, int z) {
    return (static_cast<std::size_t>(z) * static_cast<std::size_t>(base.ny) + static_cast<std::size_t>(y)) * static_cast<std::size_t>(base.nx) + static_cast<std::size_t>(x);
  };
  const std::size_t chunks = std::min<std::size_t>(4, std::max<std::size_t>(1, ps.size() / 65536));
  std::vector<std::vector<float>> partial(chunks, std::vector<float>());
  parallel_for(chunks, [&](std::size_t c0, std::size_t c1) {
    for (std::size_t c = c0; c < c1; ++c) {
      std::vector<float>& acc = partial[c];
      acc.assign(n, 0.0f);
      const std::size_t begin = ps.size() * c / chunks, end = ps.size() * (c + 1) / chunks;
      for (std::size_t i = begin; i < end; ++i) {
        const Sphere& s = ps.spheres[i];
        const SphereClip clip = ps.clip_of(i);  // a cut sphere fills only its kept part; a removed one nothing
        if (!counted(s) || clip == kSphereRemoved) continue;
        const Vec3 g = (s.center - origin_) * inv_cell - Vec3{0.5f, 0.5f, 0.5f};
        if (s.radius < cell) {  // small sphere: its volume spread trilinearly over the 8 cells around it
          const int x = floor_int(g.x), y = floor_int(g.y), z = floor_int(g.z);
          const float fx = g.x - static_cast<float>(x), fy = g.y - static_cast<float>(y), fz = g.z - static_cast<float>(z);
          const float vol = (4.0f / 3.0f) * kPi * s.radius * s.radius * s.radius * inv_cell_volume *
                            (clip == kSphereWhole ? 1.0f : ps.clip_planes.kept_fraction(s.center, s.radius, clip));
          const float wx[2] = {1 - fx, fx}, wy[2] = {1 - fy, fy}, wz[2] = {1 - fz, fz};
          if (x >= 0 && y >= 0 && z >= 0 && x + 1 < base.nx && y + 1 < base.ny && z + 1 < base.nz) {  // all 8 inside
            float* cell0 = acc.data() + index(x, y, z);
            const std::size_t sy = static_cast<std::size_t>(base.nx), sz = sy * static_cast<std::size_t>(base.ny);
            for (int k = 0; k < 8; ++k)
              cell0[(k & 1) + ((k >> 1) & 1) * sy + ((k >> 2) & 1) * sz] += vol * (wx[k & 1] * wy[(k >> 1) & 1] * wz[(k >> 2) & 1]);
            continue;
          }
          for (int k = 0; k < 8; ++k) {
            const int cx = x + (k & 1), cy = y + ((k >> 1) & 1), cz = z + ((k >> 2) & 1);
            if (cx < 0 || cy < 0 || cz < 0 || cx >= base.nx || cy >= base.ny || cz >= base.nz) continue;
            acc[index(cx, cy, cz)] += vol * (wx[k & 1] * wy[(k >> 1) & 1] * wz[(k >> 2) & 1]);
          }
          continue;
        }
        // large sphere: each cell in its box is filled by the fraction its centre is inside, a linear
        // ramp one cell wide across the surface
        const float r = s.radius * inv_cell;
        const int x0 = std::max(0, floor_int(g.x - r)), x1 = std::min(base.nx - 1, floor_int(g.x + r) + 1);
        const int y0 = std::max(0, floor_int(g.y - r)), y1 = std::min(base.ny - 1, floor_int(g.y + r) + 1);
        const int z0 = std::max(0, floor_int(g.z - r)), z1 = std::min(base.nz - 1, floor_int(g.z + r) + 1);
        for (int cz = z0; cz <= z1; ++cz)
          for (int cy = y0; cy <= y1; ++cy)
            for (int cx = x0; cx <= x1; ++cx) {
              const Vec3 d{static_cast<float>(cx) - g.x, static_cast<float>(cy) - g.y, static_cast<float>(cz) - g.z};
              const float inside = clamp(0.5f + r - length(d), 0, 1);
              if (clip != kSphereWhole && ps.clip_planes.removes(origin_ + (g + d + Vec3{0.5f, 0.5f, 0.5f}) * cell)) continue;
              if (inside > 0) acc[index(cx, cy, cz)] += inside;
            }
      }
    }
  });
  std::vector<double> bricks_density;  // split over bricks: the sum of every brick's
  if (reduction) {
    bricks_density.assign(n, 0.0);
    for (const auto& acc : partial)
      for (std::size_t i = 0; i < n; ++i) bricks_density[i] += acc[i];
    reduction->sum(bricks_density);
  }
  parallel_for(n, [&](std::size_t b0, std::size_t b1) {
    for (std::size_t i = b0; i < b1; ++i) {
      float v = 0;
      if (reduction) v = static_cast<float>(bricks_density[i]);
      else
        for (const auto& acc : partial) v += acc[i];
      // opacity across one cell: spheres of mean radius r̄ filling the fraction ρ block a ray over a
      // length ℓ with probability 1 − (1 − ρ)^(3ℓ/(4r̄)) (Beer–Lambert for small ρ, opaque at ρ = 1)
      base.value[i] = 1.0f - std::pow(1.0f - std::min(v, 1.0f), cell_exponent);
    }
  }, 1 << 14);
  // The volumes' opacity across one cell, from their shadow transfer functions at the cell centre
  // (opacity per shadow step Δ, so 1 − (1 − α)^(cell/Δ); in a full frame's refined box, the box's
  // sample), composed with the spheres'. Split over
  // bricks, each brick composes the cells whose centres its slab owns (its voxels reach them) and
  // leaves 0 in the others; the sum over the bricks is then every cell's value, exactly.
  if (occluders.has_volume()) {
    const float steps_per_cell = cell / occluders.step();
    parallel_for(static_cast<std::size_t>(base.nz), [&](std::size_t z0, std::size_t z1) {
      for (std::size_t z = z0; z < z1; ++z)
        for (int y = 0; y < base.ny; ++y)
          for (int x = 0; x < base.nx; ++x) {
            const Vec3 p = origin_ + Vec3{static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f, static_cast<float>(z) + 0.5f} * cell;
            float& value = base.value[index(x, y, static_cast<int>(z))];
            if (brick && !brick->slab.owns(p)) {
              value = 0;
              continue;
            }
            float clear = 1.0f - value;
            for (const auto& cv : occluders.volumes()) {
              if (!cv->box.contains(p) || cv->clip.removes(p)) continue;
              const CastingVolume& at = cv->finer && cv->finer->box.contains(p) ? *cv->finer : *cv;  // a refined box where it lies
              const float a = at.lut.lookup(at.volume->sample_voxel(at.volume->to_voxel(p))).a;
              if (a > 0) clear *= std::pow(1.0f - std::min(a, 0.9999f), steps_per_cell);
            }
            value = 1.0f - clear;
          }
    });
    if (brick) {
      std::vector<double> cells(base.value.begin(), base.value.end());
      brick->reduction->sum(cells);
      for (std::size_t i = 0; i < n; ++i) base.value[i] = static_cast<float>(cells[i]);
    }
  }

  // ambient.reuse compares what fills each cell from one build to the next: the filled fraction whose
  // opacity the cell has (the volumes' opacity included), which an edge of matter moving δ cells
  // changes by at most δ (the opacity itself jumps where cells are nearly full)
  filled_.clear();
  if (reuse_ > 0) {
    filled_.resize(n);
    const float inv_exponent = 1.0f / cell_exponent;
    parallel_for(n, [&](std::size_t b0, std::size_t b1) {
      for (std::size_t i = b0; i < b1; ++i) filled_[i] = 1.0f - std::pow(1.0f - std::min(base.value[i], 1.0f), inv_exponent);
    }, 1 << 14);
  }
  pyramid_.clear();
  pyramid_.push_back(std::move(base));
  // Mip levels of opacity, composed rather than averaged: along each axis a ray crosses two children
  // of a parent cell, transmitting (1 − A₁)(1 − A₂); the parent's opacity is 1 − the mean of that over
  // the 4 columns of each of the 3 axes. A wall filling half a parent is then opaque to the rays that
  // cross it and not to the others (2/3), where averaged density (1/2) would let light through as if
  // the wall were mist (cells past the edge count as empty).
  while (true) {
    const Level& f = pyramid_.back();
    if (f.nx <= 1 && f.ny <= 1 && f.nz <= 1) break;
    Level c;
    c.cell = f.cell * 2;
    c.nx = (f.nx + 1) / 2;
    c.ny = (f.ny + 1) / 2;
    c.nz = (f.nz + 1) / 2;
    c.value.resize(static_cast<std::size_t>(c.nx) * static_cast<std::size_t>(c.ny) * static_cast<std::size_t>(c.nz));
    for (int z = 0; z < c.nz; ++z)
      for (int y = 0; y < c.ny; ++y)
        for (int x = 0; x < c.nx; ++x) {
          float t[8];  // children's transmittance, index bit 0: x, bit 1: y, bit 2: z
          for (int k = 0; k < 8; ++k) t[k] = 1.0f - f.at(2 * x + (k & 1), 2 * y + ((k >> 1) & 1), 2 * z + ((k >> 2) & 1));
          float sum = 0;
          for (int axis = 0; axis < 3; ++axis) {
            const int bit = 1 << axis;
            for (int k = 0; k < 8; ++k)
              if (!(k & bit)) sum += t[k] * t[k | bit];
          }
          c.value[(static_cast<std::size_t>(z) * static_cast<std::size_t>(c.ny) + static_cast<std::size_t>(y)) * static_cast<std::size_t>(c.nx) + static_cast<std::size_t>(x)] = 1.0f - sum / 12.0f;
        }
    pyramid_.push_back(std::move(c));
  }

  // Cone directions: a Fibonacci spiral over the whole sphere, 2·directions of them, so that the
  // hemisphere of any normal holds about `directions`, each of solid angle 2π/directions.
  const int k = std::max(1, directions_);
  const float cos_half = 1.0f - 1.0f / static_cast<float>(k);
  tan_half_ = std::sqrt(std::max(0.0f, 1.0f - cos_half * cos_half)) / std::max(cos_half, 1e-3f);
  cone_dirs_.clear();
  for (int i = 0; i < 2 * k; ++i) {
    const float cz = 1.0f - (static_cast<float>(i) + 0.5f) / static_cast<float>(k);  // uniform in cos
    const float sz = std::sqrt(std::max(0.0f, 1.0f - cz * cz));
    const float phi = static_cast<float>(i) * 2.39996323f;  // golden angle
    cone_dirs_.push_back({sz * std::cos(phi), sz * std::sin(phi), cz});
  }
  // the same directions by component, padded with zero directions to a multiple of 4 (SIMD lanes)
  const std::size_t padded = (cone_dirs_.size() + 3) / 4 * 4;
  cone_x_.assign(padded, 0.0f);
  cone_y_.assign(padded, 0.0f);
  cone_z_.assign(padded, 0.0f);
  for (std::size_t c = 0; c < cone_dirs_.size(); ++c) {
    cone_x_[c] = cone_dirs_[c].x;
    cone_y_[c] = cone_dirs_[c].y;
    cone_z_[c] = cone_dirs_[c].z;
  }

  // The march is the same for every cone: distances from one cell diagonal out (past the receiver's
  // own splat), each step half the cone's diameter there, sampled at the pyramid level whose cell
  // matches that diameter.
  const int top = levels() - 1;
  steps_.clear();
  for (float d = cell * 1.7320508f; d < max_distance_;) {
    const float diameter = std::max(2.0f * d * tan_half_, cell);
    const float lod = std::min(std::log2(diameter / cell), static_cast<float>(top));
    const int l0 = static_cast<int>(lod);
    const float step = 0.5f * diameter;
    const float blend = l0 < top ? lod - static_cast<float>(l0) : 0.0f;
    // a coarse level's trilinear footprint reaches one of its cells past the fine grid's box
    const float reach = pyramid_[static_cast<std::size_t>(blend > 0 ? l0 + 1 : l0)].cell;
    steps_.push_back({d, l0, blend, reach});
    d += step;
  }
  keep_or_reset_cones(ps);
  const Level& b0 = pyramid_[0];
  grid_box_ = Box3{origin_, origin_ + Vec3{static_cast<float>(b0.nx), static_cast<float>(b0.ny), static_cast<float>(b0.nz)} * cell};
  // the volume samples' lattice: every corner unfilled until a sample needs it
  corners_x_ = b0.nx + 1, corners_y_ = b0.ny + 1, corners_z_ = b0.nz + 1;
  const std::size_t corners = static_cast<std::size_t>(corners_x_) * static_cast<std::size_t>(corners_y_) * static_cast<std::size_t>(corners_z_);
  volume_ambient_ = std::make_unique<std::atomic<std::uint32_t>[]>(corners);
  for (std::size_t c = 0; c < corners; ++c) volume_ambient_[c].store(kUnfilled, std::memory_order_relaxed);
}

void ParticleAmbientOcclusion::keep_or_reset_cones(const ParticleSet& ps) {
  const Level& base = pyramid_.front();
  spheres_kept_ = 0;
  // kept on the same grid (build chose it), for the same spheres and cones
  bool keep = reuse_ > 0 && cone_cache_.laid_out_for(ps.size(), cone_dirs_.size(), cone_cache_bytes_) &&
              traced_as_.size() == ps.size() && origin_ == kept_origin_ && base.cell == kept_base_.cell &&
              kept_base_.nx == base.nx && kept_base_.ny == base.ny && kept_base_.nz == base.nz;
  for (std::size_t i = 0; keep && i < filled_.size(); ++i) keep = std::abs(filled_[i] - kept_base_.value[i]) <= reuse_;
  if (!keep) {
    // every cone traced anew; the spheres seen only when not all fit (sphere_cone_cache.h)
    cone_cache_.reset(ps.size(), cone_dirs_.size(), cone_cache_bytes_);
    if (reuse_ > 0) {
      traced_as_ = ps.spheres;
      kept_base_ = base;
      kept_base_.value = filled_;
      kept_origin_ = origin_;
    }
    return;
  }
  // a sphere that moved (or grew) more than `reuse` cells since its cones were traced is traced anew
  const float limit = reuse_ * base.cell;
  std::atomic<std::size_t> kept{0};
  parallel_for(ps.size(), [&](std::size_t b, std::size_t e) {
    std::size_t here = 0;
    for (std::size_t i = b; i < e; ++i) {
      const Sphere& now = ps.spheres[i];
      Sphere& then = traced_as_[i];
      if (length(now.center - then.center) + std::abs(now.radius - then.radius) <= limit) {
        ++here;
        continue;
      }
      cone_cache_.forget(static_cast<std::uint32_t>(i));
      then = now;
    }
    kept.fetch_add(here, std::memory_order_relaxed);
  });
  spheres_kept_ = kept.load();
}

float ParticleAmbientOcclusion::density(int level, const Vec3& p) const {
  const Level& l = pyramid_[static_cast<std::size_t>(level)];
  const Vec3 g = (p - origin_) * (1.0f / l.cell) - Vec3{0.5f, 0.5f, 0.5f};
  const int x = floor_int(g.x), y = floor_int(g.y), z = floor_int(g.z);
  const float fx = g.x - static_cast<float>(x), fy = g.y - static_cast<float>(y), fz = g.z - static_cast<float>(z);
  if (x >= 0 && y >= 0 && z >= 0 && x + 1 < l.nx && y + 1 < l.ny && z + 1 < l.nz) {  // all 8 inside
    const std::size_t sx = 1, sy = static_cast<std::size_t>(l.nx), sz = sy * static_cast<std::size_t>(l.ny);
    const float* v = l.value.data() + static_cast<std::size_t>(z) * sz + static_cast<std::size_t>(y) * sy + static_cast<std::size_t>(x);
    const float c00 = v[0] * (1 - fx) + v[sx] * fx;
    const float c10 = v[sy] * (1 - fx) + v[sy + sx] * fx;
    const float c01 = v[sz] * (1 - fx) + v[sz + sx] * fx;
    const float c11 = v[sz + sy] * (1 - fx) + v[sz + sy + sx] * fx;
    return ((c00 * (1 - fy) + c10 * fy) * (1 - fz)) + ((c01 * (1 - fy) + c11 * fy) * fz);
  }
  const float c00 = l.at(x, y, z) * (1 - fx) + l.at(x + 1, y, z) * fx;
  const float c10 = l.at(x, y + 1, z) * (1 - fx) + l.at(x + 1, y + 1, z) * fx;
  const float c01 = l.at(x, y, z + 1) * (1 - fx) + l.at(x + 1, y, z + 1) * fx;
  const float c11 = l.at(x, y + 1, z + 1) * (1 - fx) + l.at(x + 1, y + 1, z + 1) * fx;
  return ((c00 * (1 - fy) + c10 * fy) * (1 - fz)) + ((c01 * (1 - fy) + c11 * fy) * fz);
}

float ParticleAmbientOcclusion::occlusion(const Vec3& origin, const Vec3& dir, float skip) const {
  float alpha = 0;
  bool entered = false;
  const bool from_outside = !grid_box_.contains(origin);
  for (const ConeStep& st : steps_) {
    if (st.distance < skip) continue;
    const Vec3 p = origin + dir * st.distance;
    // A receiver outside the grid (a floor) counts the coarse levels' density as far as it reaches
    // past the box, so that its AO does not jump where its cones start to meet the box; a receiver
    // inside stops at the box (beyond it is only blur of what is inside). The reach only grows along
    // the march, so a cone that left the (convex) box does not come back.
    const float reach = from_outside ? st.reach : 0.0f;
    const Vec3 r{reach, reach, reach};
    if (!Box3{grid_box_.lo - r, grid_box_.hi + r}.contains(p)) {
      if (entered) break;
      continue;            // a receiver outside the box (a floor): march until the cone enters it
    }
    entered = true;
    float rho = density(st.level, p);
    if (st.blend > 0) rho = rho * (1 - st.blend) + density(st.level + 1, p) * st.blend;
    if (rho > 0) {
      // a step of half the cone's diameter through cells (as wide as the cone) of opacity rho
      alpha += (1 - alpha) * (1.0f - std::sqrt(1.0f - std::min(rho, 0.999f)));
      if (alpha >= kEarlyTermination) break;
    }
  }
  return alpha;
}

float ParticleAmbientOcclusion::sphere_cone(std::uint32_t sphere, std::size_t cone) const {
  std::uint8_t q;
  if (!cone_cache_.get(sphere, cone, q)) {
    const Sphere& s = particles_->spheres[sphere];
    // the first radius out, the coarse cells the cone reads still hold the sphere's own fill
    const float a = occlusion(s.center + cone_dirs_[cone] * s.radius, cone_dirs_[cone], s.radius);
    // quantised whether cached or not, so that a frame does not depend on what was cached before
    q = static_cast<std::uint8_t>(a * 255.0f + 0.5f);
    cone_cache_.put(sphere, cone, q);
  }
  return static_cast<float>(q) * (1.0f / 255.0f);
}

void ParticleAmbientOcclusion::ambient(std::span<const SurfacePoint> points, std::span<Rgb> out) const {
  const std::size_t cones = cone_dirs_.size(), padded = cone_x_.size();
  // per point: each cone's cosine weight, its occlusion, and the sphere's cones stored so far; the
  // padding cones (zero directions) weigh exactly 0 and keep an occlusion of 0
  std::vector<float> weight(padded), occluded(padded, 0.0f);
  std::vector<std::uint8_t> stored(std::max(padded, SphereConeCache::kMaxCones));
  const std::uint64_t all_cones = cones >= 64 ? ~std::uint64_t{0} : (std::uint64_t{1} << cones) - 1;  // of a sphere's mask
  for (std::size_t i = 0; i < points.size(); ++i) {
    const SurfacePoint& p = points[i];
    const bool own_sphere = p.self < particles_->size();
    cone_weights(p.normal, cone_x_, cone_y_, cone_z_, weight);
    // the sphere's stored cones, read at once; the others a pixel needs (weight > 0) are traced now,
    // found from bit masks rather than by a branch per cone (half of them go each way, unpredictably)
    const std::uint64_t have = own_sphere ? cone_cache_.get_all(p.self, stored.data()) : 0;
    for (std::size_t c = 0; c < cones; ++c) occluded[c] = static_cast<float>(stored[c]) * (1.0f / 255.0f);
    for (std::size_t base = 0; base < cones && have != all_cones; base += 64) {
      const std::uint64_t needed = positive_mask(std::span<const float>(weight).subspan(base, std::min<std::size_t>(64, padded - base)));
      for (std::uint64_t m = needed & ~(base == 0 ? have : 0); m != 0; m &= m - 1) {
        const std::size_t c = base + static_cast<std::size_t>(std::countr_zero(m));
        occluded[c] = own_sphere ? sphere_cone(p.self, c) : occlusion(p.position, cone_dirs_[c], 0);
      }
    }
    // the cosine-weighted mean over the normal's hemisphere; a cone behind the normal weighs 0
    out[i] = Rgb(weighted_clearance(weight, occluded));
  }
}

float ParticleAmbientOcclusion::volume_point_ambient(const Vec3& p) const {
  if (cone_dirs_.empty()) return 1.0f;
  float sum = 0;
  for (const Vec3& d : cone_dirs_) sum += occlusion(p, d, 0);
  return 1.0f - sum / static_cast<float>(cone_dirs_.size());
}

float ParticleAmbientOcclusion::corner_ambient(int x, int y, int z) const {
  std::atomic<std::uint32_t>& slot =
      volume_ambient_[(static_cast<std::size_t>(z) * static_cast<std::size_t>(corners_y_) + static_cast<std::size_t>(y)) *
                          static_cast<std::size_t>(corners_x_) + static_cast<std::size_t>(x)];
  std::uint32_t bits = slot.load(std::memory_order_relaxed);
  if (bits == kUnfilled) {
    const float cell = pyramid_.front().cell;
    const float a = volume_point_ambient(origin_ + Vec3{static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)} * cell);
    std::memcpy(&bits, &a, sizeof bits);
    slot.store(bits, std::memory_order_relaxed);
  }
  float a;
  std::memcpy(&a, &bits, sizeof a);
  return a;
}

void ParticleAmbientOcclusion::ambient(std::span<const Vec3> points, std::span<Rgb> out) const {
  const float inv_cell = pyramid_.empty() ? 0.0f : 1.0f / pyramid_.front().cell;
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vec3 g = (points[i] - origin_) * inv_cell;
    const int x = floor_int(g.x), y = floor_int(g.y), z = floor_int(g.z);
    if (!volume_ambient_ || x < 0 || y < 0 || z < 0 || x + 1 >= corners_x_ || y + 1 >= corners_y_ || z + 1 >= corners_z_) {
      out[i] = Rgb(volume_point_ambient(points[i]));
      continue;
    }
    const float tx = g.x - static_cast<float>(x), ty = g.y - static_cast<float>(y), tz = g.z - static_cast<float>(z);
    float c[2][2][2];
    for (int dz = 0; dz < 2; ++dz)
      for (int dy = 0; dy < 2; ++dy)
        for (int dx = 0; dx < 2; ++dx) c[dz][dy][dx] = corner_ambient(x + dx, y + dy, z + dz);
    const auto lerp = [](float a, float b, float t) { return a + (b - a) * t; };
    out[i] = Rgb(lerp(lerp(lerp(c[0][0][0], c[0][0][1], tx), lerp(c[0][1][0], c[0][1][1], tx), ty),
                      lerp(lerp(c[1][0][0], c[1][0][1], tx), lerp(c[1][1][0], c[1][1][1], tx), ty), tz));
  }
}

std::size_t ParticleAmbientOcclusion::memory_bytes() const {
  std::size_t bytes = 0;
  for (const auto& l : pyramid_) bytes += l.value.capacity() * sizeof(float);
  bytes += cone_cache_.memory_bytes();
  bytes += traced_as_.capacity() * sizeof(Sphere) + (kept_base_.value.capacity() + filled_.capacity()) * sizeof(float);
  bytes += static_cast<std::size_t>(corners_x_) * static_cast<std::size_t>(corners_y_) * static_cast<std::size_t>(corners_z_) * sizeof(std::uint32_t);
  return bytes;
}

namespace {
const ParamSpec kDirections = integer_param("directions", 16, 1, 1024, "cones", "cones over the hemisphere (Staib et al. 2015)");
const ParamSpec kDensityGrid = integer_param("grid", 64, 4, 512, "cells", "density-volume cells along the spheres' longest side");
const ParamSpec kReuse = number_param("reuse", 0, 0, 8, "density cells",
                                      "keep a sphere's traced cones across rebuilds (moving atoms) while it and the matter around moved less than this; 0: trace anew");
}  // namespace

ParticleAmbientOcclusion::ParticleAmbientOcclusion(const TechniqueParams& params, std::size_t cone_cache_bytes)
    : directions_(static_cast<int>(kDirections.integer(params))), max_distance_fraction_(static_cast<float>(kAoMaxDistance.number(params))),
      grid_(static_cast<int>(kDensityGrid.integer(params))), reuse_(static_cast<float>(kReuse.number(params))),
      cone_cache_bytes_(cone_cache_bytes) {}

const TechniqueInfo& particle_ao_technique() {
  static const TechniqueInfo info{"particle_ao", TechniqueFamily::Ambient, kind_bit(ObjectKind::Spheres) | kind_bit(ObjectKind::Volume),
                                  "ambient occlusion from cones through a density pyramid of the spheres (and volumes) (Staib et al.)",
                                  {kDirections, kAoMaxDistance, kDensityGrid, kReuse},
                                  {},
                                  {},
                                  ambient_factory<ParticleAmbientOcclusion>()};
  return info;
}

}  // namespace penumbra
