#include "penumbra/particles/implicit_sphere_shadow_map.h"

#include <cmath>

#include "penumbra/core/parallel.h"
#include "penumbra/geometry/cut_sphere.h"
#include "penumbra/lighting/shared_params.h"
#include "penumbra/particles/tile_bins.h"
#include "penumbra/accel/brick_reduction.h"

namespace penumbra {

void ImplicitSphereShadowMap::build(const ShadowCasters& casters, const Light& light) {
  static const ParticleSet kNoSpheres;
  particles_ = casters.spheres().set ? casters.spheres().set : &kNoSpheres;
  light_ = light;
  const ShadowBrick* brick = casters.brick();
  reduction_ = brick && brick->own_spheres ? brick->reduction : nullptr;
  // (split over bricks, the spheres' bounds are every brick's: the renderer combines them)
  projection_ = LightProjection::fit(light, casters.spheres().set ? casters.spheres().bounds : casters.bounds());
  const int n = params_.resolution;
  const float fn = static_cast<float>(n);
  // the smallest texel of the map: at the near side for a perspective light
  const float texel = projection_.texel_size(std::max(projection_.near_depth(), 1e-6f), n);
  soft_rings_ = params_.soft_radius > 0 ? static_cast<int>(std::ceil(params_.soft_radius / texel)) : 0;

  // §3 generation: every sphere covers the texels whose centre ray hits it; the texel keeps the
  // sphere nearest to the light. Footprints (in texel units) are binned into map tiles.
  // Everything per sphere is kept in the set's spatial order (geometry/sphere_order.h): item i is the sphere
  // order.ids[i], so that a map tile reads its spheres from nearby memory.
  const ParticleSet& ps = *particles_;
  SphereOrder own_order;
  if (!casters.spheres().order) own_order = spatial_order(ps);
  const SphereOrder& order = casters.spheres().order ? *casters.spheres().order : own_order;
  std::vector<PixelRect> rects(order.size());
  std::vector<Vec3> centre_uvd;  // parallel light: each centre's map position (texels) and depth
  std::vector<float> nearest;    // parallel light: no texel ray enters a sphere before depth − r
  if (!projection_.perspective()) {
    centre_uvd.resize(order.size());
    nearest.resize(order.size());
  }
  const float texels_per_world = projection_.perspective() ? 0.0f : projection_.map_scale() * fn;
  parallel_for(order.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t i = begin; i < end; ++i) {
      const Sphere& s = order.spheres[i];
      const SphereClip clip = ps.clip_of(order.ids[i]);
      if (clip == kSphereRemoved) continue;  // clipped away: rects[i] stays empty
      if (!projection_.perspective()) {  // parallel light: the disc of radius r around the centre
        float u, v, depth;
        projection_.project(s.center, u, v, depth);
        centre_uvd[i] = {u * fn, v * fn, depth};
        nearest[i] = lower_bound_with_margin(depth - s.radius, std::abs(depth) + s.radius);
        const float r = s.radius * texels_per_world;
        if (clip == kSphereWhole) {  // the texels whose centre lies in the disc (hit() tests just that)
          centre_span(u * fn, r, n, rects[i].x0, rects[i].x1);
          centre_span(v * fn, r, n, rects[i].y0, rects[i].y1);
        } else {  // a cut sphere is met by texel rays, whose grazing hits rounding may put just outside
          pixel_span(u * fn - r, u * fn + r, n, rects[i].x0, rects[i].x1);
          pixel_span(v * fn - r, v * fn + r, n, rects[i].y0, rects[i].y1);
        }
        continue;
      }
      // perspective: the map rectangle of the sphere's bounding cube (none when part of it is
      // behind the light, which the frustum fit rules out for the spheres it was fitted to)
      float u_lo = kInfinity, u_hi = -kInfinity, v_lo = kInfinity, v_hi = -kInfinity;
      bool behind = false;
      for (int c = 0; c < 8; ++c) {
        const Vec3 corner = s.center + Vec3{(c & 1) ? s.radius : -s.radius, (c & 2) ? s.radius : -s.radius,
                                            (c & 4) ? s.radius : -s.radius};
        float u = std::nanf(""), v = std::nanf(""), depth = -1;
        projection_.project(corner, u, v, depth);
        if (!std::isfinite(u) || !std::isfinite(v) || depth <= 0) behind = true;
        u_lo = std::min(u_lo, u); u_hi = std::max(u_hi, u);
        v_lo = std::min(v_lo, v); v_hi = std::max(v_hi, v);
      }
      if (behind) continue;  // rects[i] stays empty
      pixel_span(u_lo * fn, u_hi * fn, n, rects[i].x0, rects[i].x1);
      pixel_span(v_lo * fn, v_hi * fn, n, rects[i].y0, rects[i].y1);
    }
  }, 4096);

  map_.assign(static_cast<std::size_t>(n) * static_cast<std::size_t>(n), kNoSphere);
  map_spheres_.resize(map_.size());
  std::vector<float> depth_of(reduction_ ? map_.size() : 0);
  const float world_per_texel = projection_.perspective() ? 0.0f : 1.0f / texels_per_world;
  const bool whole = ps.clip_state.empty();  // no sphere cut
  TileBins(rects, n, n).nearest_per_pixel(
      rects, nearest, order.ids, [](int, int, int, int) { return 0; },
      [&](int, std::uint32_t item, int k, int j, float) {
        const Sphere& s = order.spheres[item];
        if (!whole && ps.clip_of(order.ids[item]) != kSphereWhole) {  // a cut sphere: where the texel ray enters its kept part
          const Ray ray = projection_.texel_ray((static_cast<float>(k) + 0.5f) / fn, (static_cast<float>(j) + 0.5f) / fn);
          return intersect_particle(ps, order.ids[item], ray, -kInfinity, kInfinity);
        }
        if (!projection_.perspective()) {
          // parallel rays: the texel ray at map distance ρ from the centre enters the sphere at
          // depth(centre) − sqrt(r² − ρ²)
          const Vec3& c = centre_uvd[item];
          const float du = (static_cast<float>(k) + 0.5f - c.x) * world_per_texel;
          const float dv = (static_cast<float>(j) + 0.5f - c.y) * world_per_texel;
          const float h2 = s.radius * s.radius - du * du - dv * dv;
          return h2 >= 0 ? c.z - std::sqrt(h2) : kInfinity;
        }
        const Ray ray = projection_.texel_ray((static_cast<float>(k) + 0.5f) / fn, (static_cast<float>(j) + 0.5f) / fn);
        return intersect_sphere(ray, s, -kInfinity, kInfinity);
      },
      [&](int k, int j, float depth, std::uint32_t item) {
        const std::size_t texel_index = static_cast<std::size_t>(j) * static_cast<std::size_t>(n) + static_cast<std::size_t>(k);
        const bool none = item == TileBins::kNone;
        map_[texel_index] = none ? kNoSphere : order.ids[item];
        map_spheres_[texel_index] = none ? Sphere{} : order.spheres[item];
        if (reduction_) depth_of[texel_index] = none ? kInfinity : depth;
      });
  if (reduction_) keep_nearest_over_bricks(depth_of);
}

void ImplicitSphereShadowMap::keep_nearest_over_bricks(std::span<const float> depth_of) {
  std::vector<SphereCandidate> candidates(map_.size());
  for (std::size_t t = 0; t < map_.size(); ++t)
    if (map_[t] != kNoSphere) candidates[t] = {depth_of[t], map_spheres_[t]};
  reduction_->nearest(candidates);
  parallel_for(map_.size(), [&](std::size_t b, std::size_t e) {
    for (std::size_t t = b; t < e; ++t) {
      const SphereCandidate& c = candidates[t];
      if (c.depth == kInfinity) continue;  // no brick's sphere (this brick's texel is empty too)
      // c is the first over the bricks: it is this brick's own unless it comes before it
      const bool mine = map_[t] != kNoSphere && !c.before(SphereCandidate{depth_of[t], map_spheres_[t]});
      if (!mine) {
        map_[t] = kOtherBrickSphere;
        map_spheres_[t] = c.sphere;
      }
    }
  }, 1 << 14);
}

float ImplicitSphereShadowMap::light_at(const Vec3& position, std::uint32_t self) const {
  float u, v, depth;
  if (!projection_.project(position, u, v, depth)) return 1.0f;  // outside the map: nothing casts
  Vec3 to_light;
  float light_distance;
  light_.towards(position, to_light, light_distance);
  const int n = params_.resolution;
  const int ci = std::min(n - 1, static_cast<int>(u * static_cast<float>(n)));
  const int cj = std::min(n - 1, static_cast<int>(v * static_cast<float>(n)));
  const int t = rings();
  const bool soft = params_.soft_radius > 0;
  float light = 1.0f;
  // a sphere covers several texels in a row: testing it again gives the same answer
  std::uint32_t tested = kNoSphere;
  for (int j = std::max(0, cj - t); j <= std::min(n - 1, cj + t); ++j) {
    for (int i = std::max(0, ci - t); i <= std::min(n - 1, ci + t); ++i) {
      const std::size_t texel_index = static_cast<std::size_t>(j) * static_cast<std::size_t>(n) + static_cast<std::size_t>(i);
      const std::uint32_t id = map_[texel_index];
      if (id == kNoSphere || id == self || (id == tested && id != kOtherBrickSphere)) continue;
      tested = id;
      const Sphere& s = map_spheres_[texel_index];
      // Fig. 4: k is the distance along the shadow ray to the plane through the centre normal to it,
      // d the distance from that point to the centre, s' = d − r the ray's clearance of the surface.
      const Vec3 oc = s.center - position;
      const float k = dot(oc, to_light);
      if (k <= 0 || k >= light_distance) continue;  // behind the receiver or beyond the light
      const float d = std::sqrt(std::max(dot(oc, oc) - k * k, 0.0f));
      const float clearance = d - s.radius;
      const SphereClip clip = id == kOtherBrickSphere ? kSphereWhole : particles_->clip_of(id);
      float fringe_clearance = clearance;
      if (clip != kSphereWhole) {  // a cut sphere: its kept part, hit exactly
        if (clearance <= 0 && intersect_particle(*particles_, id, Ray{position, to_light}, 0, light_distance) < kInfinity) return 0.0f;
        if (!soft) continue;
        // the fringe grows from the kept part: the clearance of the ray's point nearest the centre
        // (which gives d − r for a whole sphere) measured to the kept part instead of the ball
        const Vec3 x = position + to_light * k;
        fringe_clearance = length(x - nearest_on_cut_sphere(x, s, particles_->clip_planes, clip));
      } else {
        if (clearance <= 0) return 0.0f;  // the shadow ray hits the sphere
        if (!soft) continue;
      }
      const float kb = k / params_.soft_distance;
      const float grown = params_.soft_radius * (1.0f - std::exp(-4.5f * kb * kb));
      if (fringe_clearance >= grown) continue;
      const float strength = std::pow(1.0f - fringe_clearance / grown, params_.soft_exponent);
      light = std::min(light, 1.0f - strength);
    }
  }
  return light;
}

void ImplicitSphereShadowMap::transmittance(std::span<const Vec3> points, std::span<Rgb> out) const {
  for (std::size_t i = 0; i < points.size(); ++i) out[i] = Rgb(light_at(points[i], kNoSphere));
}

void ImplicitSphereShadowMap::transmittance(std::span<const SurfacePoint> points, std::span<Rgb> out) const {
  for (std::size_t i = 0; i < points.size(); ++i)
    out[i] = Rgb(light_at(points[i].position, points[i].self));
}

void ImplicitSphereShadowMap::fit_to_receivers(std::span<const SurfacePoint> receivers, bool, bool) {
  if (automatic_rings_) choose_rings(receivers);
}

int ImplicitSphereShadowMap::choose_rings(std::span<const SurfacePoint> points, int max_rings, double max_changed) {
  std::vector<Rgb> previous(points.size()), current(points.size());
  auto evaluate = [&](std::vector<Rgb>& out) {
    parallel_for(points.size(), [&](std::size_t b, std::size_t e) {
      transmittance(points.subspan(b, e - b), std::span<Rgb>(out.data() + b, e - b));
    }, 4096);
  };
  set_rings(0);
  evaluate(previous);
  for (int t = 1; t <= max_rings; ++t) {
    set_rings(t);
    evaluate(current);
    std::size_t changed = 0;
    for (std::size_t i = 0; i < points.size(); ++i) changed += std::abs(current[i].r - previous[i].r) > 1.0f / 255.0f;
    // split over bricks: every brick's receivers count, so that all choose the same t
    double counts[] = {static_cast<double>(changed), static_cast<double>(points.size())};
    if (reduction_) reduction_->sum(counts);
    if (counts[0] <= max_changed * counts[1]) {
      set_rings(t - 1);  // t − 1 rings already gave this image
      return t - 1;
    }
    previous.swap(current);
  }
  return max_rings;
}

namespace {
const ParamSpec kRings = integer_param("rings", 1, -1, 64, "texels", "t, texel rings searched around the receiver's texel ((2t+1)² spheres tested, §3.1); -1: automatic, grown until the shadows stop changing (§4; --stats reports t)");
const ParamSpec kSoftRadius = number_param("soft_radius", 0, 0, 1e6, "world units", "s, virtual growth of every occluder's radius (§3.2; Å for molecules); 0: hard shadows; t is raised to cover it");
const ParamSpec kSoftExponent = number_param("soft_exponent", 1, 0.01, 100, "", "x, the penumbra's falloff (1 - s'/s)^x");
const ParamSpec kSoftDistance = number_param("soft_distance", 10, 1e-6, 1e6, "world units", "b, the occluder distance of full softness; nearer occluders give sharper shadows");
}  // namespace

const TechniqueInfo& issm_technique() {
  static const TechniqueInfo info{
      "issm", TechniqueFamily::Shadow, kind_bit(ObjectKind::Spheres),
      "implicit sphere shadow map: per texel the nearest sphere, intersected exactly at look-up (Krone et al.)",
      {kMapResolution, kRings, kSoftRadius, kSoftExponent, kSoftDistance},
      {.sphere_order = true},
      [](const TechniqueParams& p) -> std::unique_ptr<ShadowTechnique> {
        return std::make_unique<ImplicitSphereShadowMap>(IssmParams{static_cast<int>(kMapResolution.integer(p)), static_cast<int>(kRings.integer(p)),
                                                                    static_cast<float>(kSoftRadius.number(p)), static_cast<float>(kSoftExponent.number(p)),
                                                                    static_cast<float>(kSoftDistance.number(p))});
      },
      {}};
  return info;
}

}  // namespace penumbra
