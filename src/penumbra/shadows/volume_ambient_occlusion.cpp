#include "penumbra/shadows/volume_ambient_occlusion.h"

#include <cmath>

#include "penumbra/core/error.h"


namespace penumbra {
namespace {
// Eq. 5's exponent per channel: the grey one less β times the colour-weighted one.
Rgb bleed_exponent(double grey, const std::array<double, 3>& colour, double beta) {
  return {static_cast<float>(std::max(0.0, grey - beta * colour[0])), static_cast<float>(std::max(0.0, grey - beta * colour[1])),
          static_cast<float>(std::max(0.0, grey - beta * colour[2]))};
}
}  // namespace

std::vector<int> shell_half_sizes(int shells, float radius_cells) {
  std::vector<int> h;
  for (int i = 1; i <= shells; ++i) {
    const int want = static_cast<int>(std::lround(radius_cells * static_cast<float>(i) / static_cast<float>(shells)));
    h.push_back(std::max(h.empty() ? 1 : h.back() + 1, want));
  }
  return h;
}

float VolumeAmbientOcclusion::radius_cells() const {
  const auto& d = sat_->dims();
  return radius_ * static_cast<float>(std::max(d[0], std::max(d[1], d[2])));
}

void VolumeAmbientOcclusion::build(const ShadowCasters& medium) {
  sat_ = &medium.extinction_sat();
  if (bleeding_ > 0 && !sat_->has_colour())
    throw Error("ambient.bleeding needs the colour table of the extinction SAT");
  prepare();
  cache_ = CellField<Rgb>(*sat_);
  cache_.fill_near_extinction(*sat_, [&](int i, int j, int k) { return ambient_at_cell(i, j, k); });
}

Rgb VolumeAmbientOcclusion::ambient_at_cell(int i, int j, int k) const {
  const Rgb x = optical_depth(i, j, k);
  return {std::exp(-x.r), std::exp(-x.g), std::exp(-x.b)};
}

void VolumeAmbientOcclusion::ambient(std::span<const Vec3> points, std::span<Rgb> out) const {
  for (std::size_t n = 0; n < points.size(); ++n) {
    if (!cache_.try_fetch(points[n], out[n])) {  // outside the cache, or next to a cell it skipped
      const Vec3 c = sat_->to_cell(points[n]);
      out[n] = ambient_at_cell(static_cast<int>(std::floor(c.x)), static_cast<int>(std::floor(c.y)),
                               static_cast<int>(std::floor(c.z)));
    }
  }
}

void SatShellsAmbient::prepare() {
  half_sizes_ = shell_half_sizes(shells_, radius_cells());
  weights_.clear();
  const double cell = std::cbrt(static_cast<double>(sat_->cell_volume()));
  for (const int h : half_sizes_) {
    const double r = (h + 0.5) * cell;  // centre to face, world units
    weights_.push_back(sat_->cell_volume() / (4.0 * kPi * r * r));
  }
}

Rgb SatShellsAmbient::optical_depth(int i, int j, int k) const {
  double grey = 0, prev = 0;
  std::array<double, 3> colour{0, 0, 0}, prev_colour{0, 0, 0};
  const bool bleed = bleeding_ > 0;
  for (std::size_t s = 0; s < half_sizes_.size(); ++s) {  // §3.2: τ_Sh(i+1) = τ_Sh(i) + (S(Sh_i+1) − S(Sh_i)) / r²
    const int h = half_sizes_[s];
    const CellBox box{{i - h, j - h, k - h}, {i + h + 1, j + h + 1, k + h + 1}};
    const double sum = sat_->sum(box);
    grey += (sum - prev) * weights_[s];
    prev = sum;
    if (bleed) {
      const auto sc = sat_->sum_colour(box);
      for (int q = 0; q < 3; ++q) {
        colour[q] += (sc[q] - prev_colour[q]) * weights_[s];
        prev_colour[q] = sc[q];
      }
    }
  }
  return bleed_exponent(grey, colour, bleeding_);
}

void SampledAmbientOcclusion::prepare() {
  offsets_.clear();
  const Vec3 cell = sat_->cell_size();
  const double v = sat_->cell_volume();
  const Vec3 e = sat_->bounds().extent();
  const float r_world = radius_ * std::max(e.x, std::max(e.y, e.z));
  const int n[3] = {static_cast<int>(std::ceil(r_world / cell.x)), static_cast<int>(std::ceil(r_world / cell.y)),
                    static_cast<int>(std::ceil(r_world / cell.z))};
  for (int dk = -n[2]; dk <= n[2]; ++dk)
    for (int dj = -n[1]; dj <= n[1]; ++dj)
      for (int di = -n[0]; di <= n[0]; ++di) {
        const double x = di * static_cast<double>(cell.x), y = dj * static_cast<double>(cell.y),
                     z = dk * static_cast<double>(cell.z);
        const double d2 = x * x + y * y + z * z;
        if (d2 > static_cast<double>(r_world) * r_world) continue;
        const double w = d2 > 0 ? v / (4.0 * kPi * d2) : kUnitCubeInverseSquare * std::cbrt(v) / (4.0 * kPi);
        offsets_.push_back({di, dj, dk, w});
      }
}

Rgb SampledAmbientOcclusion::optical_depth(int i, int j, int k) const {
  const auto& d = sat_->dims();
  const bool bleed = bleeding_ > 0;
  double grey = 0;
  std::array<double, 3> colour{0, 0, 0};
  for (const Offset& o : offsets_) {
    const int a = i + o.di, b = j + o.dj, c = k + o.dk;
    if (a < 0 || b < 0 || c < 0 || a >= d[0] || b >= d[1] || c >= d[2]) continue;
    grey += o.weight * sat_->tau(a, b, c);
    if (bleed) {
      const Rgb tc = sat_->tau_colour(a, b, c);
      colour[0] += o.weight * tc.r;
      colour[1] += o.weight * tc.g;
      colour[2] += o.weight * tc.b;
    }
  }
  return bleed_exponent(grey, colour, bleeding_);
}

namespace {
const ParamSpec kShells = integer_param("shells", 3, 1, 64, "", "number of cuboid shells around a point (paper 001 §3.2)");
const ParamSpec kRadius = number_param("radius", 0.05, 1e-6, 1, "of the volume's longest side", "radius of the neighbourhood that occludes");
const ParamSpec kBleeding =
    number_param("bleeding", 0, 0, 1, "", "colour bleeding β: 0 grey occlusion (Eq. 4), 1 full colour (Eq. 5)");
}  // namespace

VolumeAmbientOcclusion::VolumeAmbientOcclusion(const TechniqueParams& params)
    : radius_(static_cast<float>(kRadius.number(params))), bleeding_(static_cast<float>(kBleeding.number(params))),
      shells_(static_cast<int>(kShells.integer(params))) {}

const TechniqueInfo& sat_shells_technique() {
  static const TechniqueInfo info{"sat_shells", TechniqueFamily::Ambient, kind_bit(ObjectKind::Volume) | kind_bit(ObjectKind::Spheres),
                                  "ambient occlusion and colour bleeding from cuboid shells of the 3D summed area table (Schlegel et al.)",
                                  {kShells, kRadius, kBleeding},
                                  {.extinction_sat = true},
                                  {},
                                  ambient_factory<SatShellsAmbient>()};
  return info;
}

const TechniqueInfo& sampled_ao_technique() {
  static const TechniqueInfo info{"sampled_ao", TechniqueFamily::Ambient, kind_bit(ObjectKind::Volume) | kind_bit(ObjectKind::Spheres),
                                  "sat_shells' reference: the extinction integrated over the sphere of radius `radius` voxel by voxel",
                                  {kRadius, kBleeding},
                                  {.extinction_sat = true},
                                  {},
                                  ambient_factory<SampledAmbientOcclusion>()};
  return info;
}

}  // namespace penumbra
