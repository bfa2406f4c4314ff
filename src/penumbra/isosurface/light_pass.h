// Shadows for incomplete point-based isosurfaces (paper 002 §4): a second PIsA pass from the light.
// The light's visibility buffer starts all non-visible; the receivers' light-space projections punch
// holes in it (§4.2: {F(x) = visible | x in P^l(G_e)}) — those that face the light: the others are
// unlit anyway — so the extraction from the light looks only where an eye point needs an answer and finds at most as many points as there are eye points. Each
// light pixel keeps the light distance of the nearest surface found; a receiver is lit when it is no
// farther from the light than that, plus a bias (docs/techniques/point_isosurface.md). The light frustum is
// fitted to the receivers in light coordinates with an asymmetric perspective window (§4.3, Fig. 5 C);
// `volume` fits it to the whole volume box instead (Fig. 5 A), for comparison. Directional lights use
// an orthographic view fitted the same way. The far-subvolume collapse is off in this pass (§4.3).
//
// | parameter             | default   | meaning                                                        |
// | shadows.resolution    | 1024      | light visibility buffer pixels per side (the paper: 512)       |
// | shadows.light_frustum | tight     | tight (fitted to the receivers, §4.3) or volume (the box)      |
// | shadows.bias          | automatic | world units added to the stored light distance (see the page)  |
#pragma once

#include <string>
#include <vector>

#include "penumbra/isosurface/point_extraction.h"
#include "penumbra/accel/brick_reduction.h"
#include "penumbra/lighting/shadow_technique.h"
#include "penumbra/lighting/technique_info.h"
#include "penumbra/isosurface/view_projection.h"
#include "penumbra/isosurface/visibility_buffer.h"

namespace penumbra {

enum class LightFrustum { Tight, Volume };
LightFrustum light_frustum_from_string(const std::string& name);  // "tight", "volume"
std::string to_string(LightFrustum f);

const TechniqueInfo& light_pass_technique();

// The scene file's shadows.resolution, light_frustum and bias (declared in light_pass_technique()).
struct LightPassSettings {
  int resolution;        // light visibility buffer pixels per side (the paper: 512, as the screen)
  LightFrustum frustum;
  float bias;            // world units added to the stored light distance; < 0: automatic
};

// The light's view for a set of receivers (§4.3). Points behind a point light's plane are left out
// (they are lit: no perspective frustum from the light holds them). With a reduction, each brick passes
// its share of the receivers and every brick gets the view of all of them.
ViewProjection fit_light_view(const Light& light, std::span<const IsoPoint> receivers, const Box3& volume_box,
                              const LightPassSettings& settings, BrickReduction* reduction = nullptr);

// One isosurface seen from one light for one frame's receivers: the light pass proper.
struct IsosurfaceLightPass {
  ViewProjection view;
  VisibilityBuffer holes;        // the buffer the light pass started from
  Extraction light_points;
  std::vector<float> depth;        // per light pixel: nearest light distance found; infinity: none
  std::vector<float> depth_error;  // per light pixel: that point's position error
  float crease = 0;                // the bias's share for the surface's creases: a tenth of its voxel
  // A refined box (CastingIsosurface::finer): per light pixel 1 when its point lies on the box's finer
  // surface (empty when there is no box), the box and a tenth of its voxel. A receiver inside the box
  // against such a point is biased by the finer crease; every other pair by the opened level's.
  std::vector<std::uint8_t> finer_point;
  Box3 finer_box;
  float finer_crease = 0;
  std::size_t hole_count = 0;

  // The crease share of the bias for a receiver at `p` against light pixel k.
  float crease_at(std::size_t k, const Vec3& p) const {
    return !finer_point.empty() && finer_point[k] && finer_box.contains(p) ? finer_crease : crease;
  }
};

// Takes isosurfaces only (the catalogue): one light pass per isosurface, a receiver's light the
// product of theirs. When volume samples receive too (a visible volume in the scene), every light pixel
// is open and the frustum is the isosurface's volume box: the pass can no longer be limited to the
// eye's points, since any sample of the volume may ask.
class LightPass final : public ShadowTechnique {
public:
  using ShadowTechnique::transmittance;
  explicit LightPass(LightPassSettings settings) : settings_(settings) {}
  void build(const ShadowCasters& casters, const Light& light) override;
  // With `refined`, an isosurface with a refined box (CastingIsosurface::finer) is extracted from it
  // inside the box, as the eye pass drew it; a preview's receivers meet the opened level's surface only.
  void fit_to_receivers(std::span<const SurfacePoint> receivers, bool volume_samples, bool refined) override;
  bool view_dependent() const override { return true; }
  // On a brick (accel/brick_reduction.h): its share of the receivers and its isosurface cells; the fit,
  // the holes (a hole of any brick) and each light pixel's nearest depth combine over the bricks.
  bool combines_over_bricks() const override { return true; }
  void transmittance(std::span<const Vec3> points, std::span<Rgb> out) const override;
  void transmittance(std::span<const SurfacePoint> points, std::span<Rgb> out) const override;
  Vec3 surface_receiver(const Vec3& p, const Vec3&) const override { return p; }  // the bias is applied per query
  void add_stats(ShadowStats& stats) const override;
  std::size_t memory_bytes() const override;
  std::string_view name() const override { return "light_pass"; }

  const std::vector<IsosurfaceLightPass>& passes() const { return passes_; }  // one per isosurface
  double build_ms() const { return build_ms_; }
  // The bias for a receiver at light distance d, placed to within `error` of the surface, whose normal
  // makes cos_theta with the light direction, against a light point placed to within `light_error`, on
  // a surface whose creases take `crease` (IsosurfaceLightPass::crease).
  float bias(const ViewProjection& view, float distance, float cos_theta, float error, float light_error, float crease) const;

private:
  // 1 when lit, 0 when an isosurface is in front (cos_theta: the receiver's normal against the light).
  float light_at(const Vec3& p, float cos_theta, float error) const;

  LightPassSettings settings_;
  const ShadowCasters* casters_ = nullptr;
  Light light_;
  std::vector<IsosurfaceLightPass> passes_;
  double build_ms_ = 0;
};

}  // namespace penumbra
