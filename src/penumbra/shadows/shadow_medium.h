// What a light sees: the absorbing volume under the shadow transfer function and the opaque planes.
// Every shadow technique reads the scene through this one class, so they all share one colour model
// (DESIGN.md): a segment with opacity α and transmission colour t passes light of channel λ with
// probability 1 − α·(1 − t_λ); opaque planes pass nothing. A volume with extinction compositing
// (paper 001) attenuates every channel alike, t = 0, so a segment passes exp(−τ·Δs) (paper 001, Eq. 7).
// The extinction techniques (sat_cone, sat_shells) also read the volume's 3D summed area table from
// here, once the renderer has attached it.
#pragma once

#include <cmath>
#include <vector>

#include "penumbra/accel/extinction_sat.h"
#include "penumbra/accel/macrocell_grid.h"
#include "penumbra/core/color.h"
#include "penumbra/core/cutoffs.h"
#include "penumbra/core/math.h"
#include "penumbra/data/transfer_function.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

// Light rays sample the volume once per voxel unless shadows.step says otherwise: the light pass is
// only integrated, never shaded, so it does not need the eye's finer step; all techniques, the
// ray-traced reference included, use the same step, so their differences are the techniques' own.
constexpr float kDefaultShadowStepVoxels = 1.0f;

struct MediumSegment {
  std::int64_t index;  // k: the segment [k·Δ, (k+1)·Δ] of the ray's lattice
  float t;             // midpoint of the part of the segment inside the volume
  float t_begin, t_end;  // that part's ends (a full segment is [kΔ, (k+1)Δ]; the box cuts the first and last)
  float alpha;         // opacity of that part (corrected for its length)
  Rgb transmission;    // t_λ: colour passed when the light interacts (the shadow TF's colour)
};

class ShadowMedium {
public:
  // `grid` is the visible volume's macrocell grid (shared with the ray caster; must outlive this).
  ShadowMedium(const Scene& scene, const MacrocellGrid& grid);

  bool has_volume() const { return volume_ != nullptr; }
  float step() const { return step_; }                 // Δ, world units
  const Box3& bounds() const { return bounds_; }       // what light frusta are fitted to
  const std::vector<Plane>& planes() const { return *planes_; }

  // Ray parameter of the nearest opaque plane in (t0, t1), or infinity.
  float surface_hit(const Ray& r, float t0, float t1) const {
    float best = kInfinity;
    for (const auto& p : *planes_) best = std::min(best, p.intersect(r, t0, t1));
    return best;
  }

  // Visits the volume segments of r inside [t_begin, t_end] in order (lattice k·Δ from the ray origin),
  // skipping empty macrocells; visit(segment) returns false to stop.
  template <class Visit>
  void march(const Ray& r, float t_begin, float t_end, Visit&& visit) const {
    if (!volume_) return;
    float t0, t1;
    if (!volume_box_.clip(r, t0, t1, t_begin, t_end)) return;
    const EmptySpaceSkipper skipper(*volume_, *grid_, empty_);
    std::size_t last_cell = SIZE_MAX;
    std::int64_t k = static_cast<std::int64_t>(std::floor(t0 / step_));
    while (true) {
      // segment k is [kΔ, (k+1)Δ]; only the first and last are cut by the box
      const float lo = static_cast<float>(k) * step_;
      const float seg0 = lo < t0 ? t0 : lo;
      const float hi = lo + step_;
      const float seg1 = hi > t1 ? t1 : hi;
      if (seg0 >= t1) return;
      if (seg1 <= seg0) { ++k; continue; }
      const float tm = 0.5f * (seg0 + seg1);
      const Vec3 p = r.at(tm);
      const Vec3 v = volume_->to_voxel(p);
      const std::size_t cell = skipper.cell_of(v);
      if (cell != last_cell) {
        last_cell = cell;
        if (skipper.empty(cell)) {  // empty cell: continue with the segment that holds the cell's exit
          const float t_skip = skipper.cell_exit(r, tm, v);
          k = std::max(k + 1, static_cast<std::int64_t>(std::floor(t_skip / step_)));
          last_cell = SIZE_MAX;
          continue;
        }
      }
      const Rgba s = lut_.lookup(volume_->sample_voxel(v));
      if (s.a > 0) {
        const float len = seg1 - seg0;
        const float a = len >= step_ * 0.9999f ? s.a : 1.0f - std::pow(1.0f - s.a, len / step_);
        if (!visit(MediumSegment{k, tm, seg0, seg1, a, achromatic_ ? Rgb(0.0f) : s.rgb})) return;
      }
      ++k;
    }
  }

  // Exact transmittance along r over [t_begin, t_end] (the product of the colour model over all
  // segments, zero if a plane is hit), stopping early below kShadowOpaque.
  Rgb transmittance(const Ray& r, float t_begin, float t_end) const {
    if (surface_hit(r, t_begin, t_end) < kInfinity) return Rgb(0.0f);
    Rgb T(1.0f);
    march(r, t_begin, t_end, [&](const MediumSegment& s) {
      T *= Rgb(1.0f) - (Rgb(1.0f) - s.transmission) * s.alpha;
      return T.max_component() > kShadowOpaque;
    });
    return T;
  }

  std::size_t memory_bytes() const { return empty_.size(); }

  // The extinction SAT of the visible volume, attached by the renderer for the techniques that need it.
  void attach_extinction_sat(const ExtinctionSat* sat) { sat_ = sat; }
  const ExtinctionSat& extinction_sat() const;  // throws Error when none is attached (no volume)

private:
  const Volume* volume_ = nullptr;
  const std::vector<Plane>* planes_ = nullptr;
  Box3 volume_box_, bounds_;
  float step_ = 1;
  TransferLut lut_;
  const MacrocellGrid* grid_ = nullptr;
  std::vector<std::uint8_t> empty_;
  bool achromatic_ = false;
  const ExtinctionSat* sat_ = nullptr;
};

}  // namespace penumbra
