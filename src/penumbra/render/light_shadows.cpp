#include "penumbra/render/light_shadows.h"

#include <array>

#include "penumbra/registry/technique_catalog.h"
#include "penumbra/registry/registry.h"

namespace penumbra {

LightShadows::LightShadows(const Scene& scene, const ShadowCasters& all, const Light& light, const ShadowBrick* brick) {
  for (const ShadowAssignment& a : shadow_assignments(scene)) {
    auto technique = make_shadow_technique(a.technique, scene.shadows);
    ShadowCasters casters = all.restricted_to(a.casters);
    if (brick != nullptr && technique->combines_over_bricks()) casters = casters.restricted_to_brick(*brick);
    casters_.push_back(std::make_unique<ShadowCasters>(std::move(casters)));
    technique->build(*casters_.back(), light);
    techniques_.push_back(std::move(technique));
  }
}

void LightShadows::fit_to_receivers(std::span<const SurfacePoint> receivers, bool volume_samples, bool refined) {
  for (auto& t : techniques_) t->fit_to_receivers(receivers, volume_samples, refined);
}

namespace {

// out = Π over the techniques of their answers, in batches of 64.
template <class Point>
void product(const std::vector<std::unique_ptr<ShadowTechnique>>& techniques, std::span<const Point> points,
             std::span<Rgb> out) {
  if (techniques.size() == 1) {  // the common case: no product to form
    techniques.front()->transmittance(points, out);
    return;
  }
  for (auto& o : out) o = Rgb(1.0f);
  std::array<Rgb, 64> one;
  for (std::size_t b = 0; b < points.size(); b += one.size()) {
    const std::size_t n = std::min(one.size(), points.size() - b);
    for (const auto& t : techniques) {
      t->transmittance(points.subspan(b, n), std::span<Rgb>(one.data(), n));
      for (std::size_t i = 0; i < n; ++i) out[b + i] *= one[i];
    }
  }
}

}  // namespace

void LightShadows::transmittance(std::span<const Vec3> points, std::span<Rgb> out) const {
  product(techniques_, points, out);
}

void LightShadows::transmittance(std::span<const SurfacePoint> points, std::span<Rgb> out) const {
  product(techniques_, points, out);
}

std::size_t LightShadows::memory_bytes() const {
  std::size_t bytes = 0;
  for (const auto& t : techniques_) bytes += t->memory_bytes();
  return bytes;
}

void LightShadows::add_stats(ShadowStats& stats) const {
  for (const auto& t : techniques_) t->add_stats(stats);
}

}  // namespace penumbra
