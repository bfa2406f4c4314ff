// Sphere rendering, implicit sphere shadow maps and particle ambient occlusion, each against its exact
// counterpart: Embree rays for the visible spheres, shadow rays for ISSM, Monte-Carlo rays for AO.
#include <gtest/gtest.h>

#include <cmath>
#include <atomic>
#include <cstdio>
#include <random>
#include <memory>

#include "penumbra/registry/technique_catalog.h"
#include "penumbra/core/parallel.h"
#include "penumbra/geometry/cut_sphere.h"
#include "penumbra/particles/implicit_sphere_shadow_map.h"
#include "penumbra/particles/particle_ambient_occlusion.h"
#include "penumbra/shadows/ray_traced.h"
#include "penumbra/shadows/ray_traced_ao.h"
#include "penumbra/particles/sphere_hits.h"
#include "penumbra/particles/sphere_cone_cache.h"
#include "penumbra/particles/tile_bins.h"
#include "penumbra/render/surface_frame.h"
#include "penumbra/render/renderer.h"
#include "image_check.h"
#include "test_scenes.h"

namespace penumbra {
namespace {

// A particle set with its BVH and the casters the techniques take (the spheres alone).
struct SphereWorld {
  explicit SphereWorld(ParticleSet set) : particles(std::move(set)), view(Scene{}, {}) {
    bvh = std::make_unique<SphereBvh>(particles);
    view.set_spheres(CastingSpheres{&particles, bvh.get(), particles.bounds()});
  }
  ParticleSet particles;
  std::unique_ptr<SphereBvh> bvh;
  ShadowCasters view;
};

ParticleSet spheres(std::initializer_list<Sphere> list) {
  ParticleSet p;
  for (const auto& s : list) {
    p.spheres.push_back(s);
    p.colors.push_back(pack_rgba8(Rgb(0.8f)));
  }
  return p;
}

Light directional(const Vec3& dir) {
  Light l;
  l.direction = normalize(dir);
  return l;
}

// Points on the surfaces of a frame of `set` seen by `camera` (spheres only, no planes).
std::vector<SurfacePoint> frame_points(const SphereWorld& w, const Camera& camera) {
  Scene scene;
  scene.particles.push_back(ParticleObject{});
  scene.particles.back().set = std::shared_ptr<const ParticleSet>(&w.particles, [](const ParticleSet*) {});
  const SphereHits hits = splat_spheres(w.particles, camera);
  const std::uint32_t offsets[] = {0, static_cast<std::uint32_t>(w.particles.size())}, objects[] = {0};
  const SurfaceInputs in{&scene, &camera, &w.particles, offsets, objects, &hits, {}};
  return visible_surfaces(in).points;
}

Camera looking_at(const Box3& b, int size, const Vec3& dir = {1.0f, 0.8f, 1.2f}) {
  Camera c;
  c.target = b.center();
  c.eye = b.center() + normalize(dir) * (2.4f * b.radius());
  c.width = c.height = size;
  return c;
}

// The (grey) light fractions of a technique, and the ambient factors of an ambient technique.
std::vector<float> fractions(const ShadowTechnique& t, const std::vector<SurfacePoint>& pts) {
  std::vector<Rgb> rgb(pts.size());
  t.transmittance(std::span<const SurfacePoint>(pts), std::span<Rgb>(rgb));
  std::vector<float> out;
  for (const Rgb& c : rgb) out.push_back(c.r);
  return out;
}

std::vector<float> ambient_of(const AmbientTechnique& t, const std::vector<SurfacePoint>& pts) {
  std::vector<Rgb> rgb(pts.size());
  t.ambient(std::span<const SurfacePoint>(pts), std::span<Rgb>(rgb));
  std::vector<float> out;
  for (const Rgb& c : rgb) out.push_back(c.r);
  return out;
}

// Points that face the light: only there does a shadow change the shading (the others get no direct
// light at all, and the ray-traced reference finds them shadowed by their own sphere).
std::vector<SurfacePoint> facing(const std::vector<SurfacePoint>& pts, const Light& light) {
  std::vector<SurfacePoint> out;
  for (const auto& p : pts) {
    Vec3 to_light;
    float d;
    light.towards(p.position, to_light, d);
    if (dot(p.normal, to_light) > 0) out.push_back(p);
  }
  return out;
}

double disagreement(const std::vector<float>& a, const std::vector<float>& b) {
  std::size_t n = 0;
  for (std::size_t i = 0; i < a.size(); ++i) n += (a[i] > 0.5f) != (b[i] > 0.5f);
  return static_cast<double>(n) / static_cast<double>(a.size());
}

TEST(SphereHits, SplattingFindsTheSameSpheresAsEmbreeRays) {
  const SphereWorld w(random_spheres(3000, 0.03f, 7));
  const Camera cam = looking_at(w.view.bounds(), 200);
  const SphereHits a = splat_spheres(w.particles, cam);
  const SphereHits b = trace_spheres(*w.bvh, cam);
  std::size_t same = 0, covered = 0;
  for (std::size_t i = 0; i < a.id.size(); ++i) {
    covered += b.id[i] != kNoSphere;
    if (a.id[i] != b.id[i]) continue;
    ++same;
    if (a.id[i] != kNoSphere) {
      EXPECT_NEAR(a.t[i], b.t[i], 1e-4f * b.t[i]);
    }
  }
  EXPECT_GT(covered, a.id.size() / 4);
  // the two differ only on silhouettes, where rays graze a sphere and float rounding decides
  EXPECT_GE(static_cast<double>(same) / static_cast<double>(a.id.size()), 0.999);
}

// Hemispheres of random discs stacked 60 deep over a 200² raster: with each item's nearest possible
// distance given, the nearest item per pixel (ties included: equal depths are made common by rounding)
// is exactly the one found without the bounds, while most hit() calls are skipped.
TEST(TileBins, HiddenItemsAreSkippedWithoutChangingTheNearest) {
  constexpr int kSize = 200;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> pos(0, kSize), radius(3, 12), depth(0, 50);
  struct Disc { float x, y, z, r; };
  std::vector<Disc> discs(60 * kSize * kSize / 250);
  std::vector<PixelRect> rects(discs.size());
  std::vector<float> nearest(discs.size());
  for (std::size_t i = 0; i < discs.size(); ++i) {
    Disc& d = discs[i];
    d = {pos(rng), pos(rng), std::round(depth(rng)), radius(rng)};
    pixel_span(d.x - d.r, d.x + d.r, kSize, rects[i].x0, rects[i].x1);
    pixel_span(d.y - d.r, d.y + d.r, kSize, rects[i].y0, rects[i].y1);
    nearest[i] = std::floor(d.z - d.r);  // below every rounded distance hit() returns
  }
  // items[k] is the disc discs[disc_of[k]] (identity when disc_of is empty)
  auto nearest_items = [&](std::span<const float> bounds, std::atomic<std::size_t>& calls, std::span<const std::uint32_t> disc_of = {}) {
    std::vector<PixelRect> item_rects = rects;
    std::vector<float> item_bounds(bounds.begin(), bounds.end());
    for (std::size_t k = 0; k < disc_of.size(); ++k) {
      item_rects[k] = rects[disc_of[k]];
      if (!bounds.empty()) item_bounds[k] = bounds[disc_of[k]];
    }
    std::vector<std::uint32_t> ids(kSize * kSize, 7);
    std::vector<float> t(kSize * kSize, -1);
    TileBins(item_rects, kSize, kSize).nearest_per_pixel(
        item_rects, item_bounds, disc_of, [](int, int, int, int) { return 0; },
        [&](int, std::uint32_t item, int x, int y, float) {
          calls.fetch_add(1, std::memory_order_relaxed);
          const Disc& d = discs[disc_of.empty() ? item : disc_of[item]];
          const float dx = static_cast<float>(x) + 0.5f - d.x, dy = static_cast<float>(y) + 0.5f - d.y;
          const float h2 = d.r * d.r - dx * dx - dy * dy;
          return h2 >= 0 ? std::round(d.z - std::sqrt(h2)) : kInfinity;  // rounded: many ties
        },
        [&](int x, int y, float depth_here, std::uint32_t item) {
          ids[static_cast<std::size_t>(y * kSize + x)] = item == TileBins::kNone || disc_of.empty() ? item : disc_of[item];
          t[static_cast<std::size_t>(y * kSize + x)] = depth_here;
        });
    return std::make_pair(ids, t);
  };
  std::atomic<std::size_t> all_calls{0}, bounded_calls{0}, reversed_calls{0};
  const auto all = nearest_items({}, all_calls);
  const auto bounded = nearest_items(nearest, bounded_calls);
  EXPECT_EQ(all.first, bounded.first);
  EXPECT_EQ(all.second, bounded.second);
  EXPECT_LT(bounded_calls.load(), all_calls.load() / 4) << "the bounds skipped too few items";
  // the items in reverse order, each with its disc's id: ties still go to the lower disc
  std::vector<std::uint32_t> reversed(discs.size());
  for (std::size_t k = 0; k < discs.size(); ++k) reversed[k] = static_cast<std::uint32_t>(discs.size() - 1 - k);
  const auto in_reverse = nearest_items(nearest, reversed_calls, reversed);
  EXPECT_EQ(all.first, in_reverse.first);
  EXPECT_EQ(all.second, in_reverse.second);
}

// centre_span holds exactly the pixels whose centres lie within [c − r, c + r] (a hundredth of a pixel
// to spare), clamped to the raster, against a count of every pixel.
TEST(TileBins, CentreSpanHoldsExactlyThePixelsWhoseCentreIsInside) {
  constexpr int n = 40;
  for (int k = 0; k < 20000; ++k) {
    const float c = uniform_float(17, static_cast<std::uint64_t>(k), 0) * 50.0f - 5.0f;
    const float r = uniform_float(17, static_cast<std::uint64_t>(k), 1) * 6.0f;
    int i0 = 0, i1 = 0;
    centre_span(c, r, n, i0, i1);
    for (int i = 0; i < n; ++i) {
      const float d = std::abs(static_cast<float>(i) + 0.5f - c);
      if (d <= r) {
        EXPECT_TRUE(i >= i0 && i <= i1) << "c " << c << " r " << r << " pixel " << i << " left out";
      }
      if (d > r + 0.011f) {
        EXPECT_FALSE(i >= i0 && i <= i1) << "c " << c << " r " << r << " pixel " << i << " taken";
      }
    }
  }
}

TEST(SphereHits, SplattingIsTheSameForAnyThreadCount) {
  const ParticleSet set = random_spheres(2000, 0.04f, 3);
  const Camera cam = looking_at(set.bounds(), 120);
  SphereHits one, two;
  {
    ThreadLimit l(1);
    one = splat_spheres(set, cam);
  }
  {
    ThreadLimit l(2);
    two = splat_spheres(set, cam);
  }
  EXPECT_EQ(one.id, two.id);
  EXPECT_EQ(one.t, two.t);
}

// Each sphere twice (the copies' ids after the originals', so every covered pixel is a tie): the
// splat gives the same ids and distances in the set's spatial order, in the set's own order and in the
// reverse of it, and every pixel goes to the original.
TEST(SphereHits, SplattingDoesNotDependOnTheOrderOfTheSpheres) {
  ParticleSet set = random_spheres(3000, 0.04f, 11);
  const std::size_t n = set.size();
  set.spheres.insert(set.spheres.end(), set.spheres.begin(), set.spheres.end());
  set.colors.insert(set.colors.end(), set.colors.begin(), set.colors.end());
  const Camera cam = looking_at(set.bounds(), 160);
  SphereOrder own, reverse;
  for (std::uint32_t i = 0; i < set.size(); ++i) {
    own.ids.push_back(i);
    own.spheres.push_back(set.spheres[i]);
  }
  reverse.ids.assign(own.ids.rbegin(), own.ids.rend());
  reverse.spheres.assign(own.spheres.rbegin(), own.spheres.rend());
  const SphereHits spatial = splat_spheres(set, cam), in_order = splat_spheres(set, own, cam), reversed = splat_spheres(set, reverse, cam);
  EXPECT_EQ(spatial.id, in_order.id);
  EXPECT_EQ(spatial.t, in_order.t);
  EXPECT_EQ(reversed.id, in_order.id);
  EXPECT_EQ(reversed.t, in_order.t);
  EXPECT_GT(spatial.covered(), spatial.id.size() / 4);
  for (const std::uint32_t id : spatial.id) ASSERT_TRUE(id == kNoSphere || id < n) << "a copy won a tie";
  // the implicit sphere shadow map's splat, under a parallel and a point light: the same texels
  Light point;
  point.type = LightType::Point;
  point.position = {2, 3, 1};
  for (const Light& light : {directional({-0.3f, -1, -0.2f}), point}) {
    SCOPED_TRACE(light.type == LightType::Point ? "point light" : "directional light");
    auto texels = [&](const SphereOrder* order) {
      ShadowCasters view{Scene{}, {}};
      view.set_spheres(CastingSpheres{&set, nullptr, set.bounds(), order});
      ImplicitSphereShadowMap map(IssmParams{256, 1, 0, 1, 1});
      map.build(view, light);
      std::vector<std::uint32_t> ids;
      for (int j = 0; j < map.resolution(); ++j)
        for (int i = 0; i < map.resolution(); ++i) ids.push_back(map.texel(i, j));
      return ids;
    };
    const auto spatial_texels = texels(nullptr), own_texels = texels(&own), reversed_texels = texels(&reverse);
    EXPECT_EQ(spatial_texels, own_texels);
    EXPECT_EQ(reversed_texels, own_texels);
    std::size_t covered = 0;
    for (const std::uint32_t id : spatial_texels) {
      ASSERT_TRUE(id == kNoSphere || id < n) << "a copy won a tie";
      covered += id != kNoSphere;
    }
    EXPECT_GT(covered, spatial_texels.size() / 8);
  }
}

TEST(Issm, NoSphereShadowsItself) {
  const SphereWorld w(spheres({{{0, 0, 0}, 1.0f}}));
  const Light light = directional({-0.3f, -1, -0.2f});
  ImplicitSphereShadowMap map(IssmParams{64, 2, 0, 1, 1});
  map.build(w.view, light);
  const auto pts = frame_points(w, looking_at(w.view.bounds(), 64));
  ASSERT_GT(pts.size(), 500u);
  for (float f : fractions(map, pts)) EXPECT_EQ(f, 1.0f);
}

TEST(Issm, ASphereBehindAnotherAlongTheLightIsFullyShadowed) {
  const Vec3 l = normalize(Vec3{-0.3f, -1, -0.2f});
  const SphereWorld w(spheres({{{0, 0, 0}, 1.0f}, {l * 3.0f, 0.5f}}));
  ImplicitSphereShadowMap map(IssmParams{128, 1, 0, 1, 1});
  map.build(w.view, directional(l));
  // every point of the small sphere that faces the light
  std::vector<SurfacePoint> pts;
  for (int i = 0; i < 400; ++i) {
    const float z = 1.0f - 2.0f * (static_cast<float>(i) + 0.5f) / 400.0f;
    const float r = std::sqrt(1 - z * z), phi = static_cast<float>(i) * 2.39996323f;
    const Vec3 n{r * std::cos(phi), r * std::sin(phi), z};
    if (dot(n, -l) <= 0) continue;
    pts.push_back({l * 3.0f + n * 0.5f, n, 1u});
  }
  ASSERT_GT(pts.size(), 150u);
  for (float f : fractions(map, pts)) EXPECT_EQ(f, 0.0f);
}

// A cluster of spheres over a floor of spheres: many shadow boundaries.
ParticleSet shadow_test_set() {
  ParticleSet set = random_spheres(1500, 0.025f, 11);
  for (int i = 0; i < 60; ++i)
    for (int j = 0; j < 60; ++j) {
      set.spheres.push_back({{-0.9f + 0.03f * static_cast<float>(i), -0.75f, -0.9f + 0.03f * static_cast<float>(j)}, 0.02f});
      set.colors.push_back(pack_rgba8(Rgb(0.8f)));
    }
  return set;
}

TEST(Issm, TheMapIsTheSameForAnyThreadCount) {
  const SphereWorld w(shadow_test_set());
  for (const Light& light : {directional({-0.35f, -1, -0.25f}), [] {
         Light l;
         l.type = LightType::Point;
         l.position = {0.8f, 2.5f, 0.6f};
         return l;
       }()}) {
    ImplicitSphereShadowMap one(IssmParams{256, 1, 0, 1, 1}), two(IssmParams{256, 1, 0, 1, 1});
    {
      ThreadLimit l(1);
      one.build(w.view, light);
    }
    {
      ThreadLimit l(2);
      two.build(w.view, light);
    }
    std::size_t filled = 0;
    for (int j = 0; j < 256; ++j)
      for (int i = 0; i < 256; ++i) {
        ASSERT_EQ(one.texel(i, j), two.texel(i, j)) << i << ", " << j;
        filled += one.texel(i, j) != kNoSphere;
      }
    EXPECT_GT(filled, 256u * 256u / 10);  // the maps hold something to compare
  }
}

TEST(Issm, HardShadowsAgreeWithShadowRaysAndImproveWithRingsAndResolution) {
  const SphereWorld w(shadow_test_set());
  const Light light = directional({-0.35f, -1, -0.25f});
  const auto pts = facing(frame_points(w, looking_at(w.view.bounds(), test::sanitize_scale() ? 96 : 192)), light);
  RayTracedShadows exact(0, 1);
  exact.build(w.view, light);
  const auto ref = fractions(exact, pts);
  auto issm = [&](int res, int rings) {
    ImplicitSphereShadowMap map(IssmParams{res, rings, 0, 1, 1});
    map.build(w.view, light);
    return disagreement(fractions(map, pts), ref);
  };
  std::size_t shadowed = 0;
  for (float f : ref) shadowed += f < 0.5f;
  EXPECT_GT(shadowed, pts.size() / 10);  // the test has shadows to get right
  const double t0 = issm(512, 0), t1 = issm(512, 1), t2 = issm(512, 2), t0_hi = issm(1024, 0), t1_hi = issm(1024, 1);
  // t = 1 with an adequate map (texel ≈ 1/6 of a sphere radius): only points at shadow boundaries
  // differ (measured 0.03 %)
  EXPECT_LT(t1, 0.002);
  // t = 0 shows the paper's Fig. 3 artefacts: occluders missed between texel centres (measured 1.4 %)
  EXPECT_GT(t0, 4 * t1);
  EXPECT_LE(t2, t1);
  EXPECT_LT(t0_hi, t0);  // a finer map misses fewer
  EXPECT_LE(t1_hi, t1);
}

// The automatic t (paper 003 §4) must stop where the image stops changing, and not before: at the chosen
// t the light fractions equal those of the converged map (t = 8 rings: every sphere here is ≤ 0.025 in
// radius, under 2 texels of the coarse 128² map, so no occluder lies farther) except on at most the
// chooser's own threshold (1e-4 of the points changing by > 1/255), and at t − 1 they did not (more
// than that threshold differ) — so a chooser that stopped a ring early or late fails. The coarse map
// needs rings (t ≥ 1, so "did change before" is exercised), a finer map needs no more.
TEST(Issm, AutomaticRingsStopWhenTheImageStopsChanging) {
  const SphereWorld w(shadow_test_set());
  const Light light = directional({-0.35f, -1, -0.25f});
  const auto pts = facing(frame_points(w, looking_at(w.view.bounds(), 96)), light);
  const double threshold = 1e-4 * static_cast<double>(pts.size());  // choose_issm_rings' default max_changed
  auto changed = [](const std::vector<float>& a, const std::vector<float>& b) {
    std::size_t n = 0;
    for (std::size_t i = 0; i < a.size(); ++i) n += std::abs(a[i] - b[i]) > 1.0f / 255.0f;
    return static_cast<double>(n);
  };
  std::vector<int> chosen;
  for (const int res : {128, 1024}) {
    SCOPED_TRACE("map " + std::to_string(res));
    ImplicitSphereShadowMap map(IssmParams{res, 0, 0, 1, 1});
    map.build(w.view, light);
    const int t = map.choose_rings(pts);
    EXPECT_EQ(map.rings(), t) << "the map is left at the chosen t";
    const auto at_t = fractions(map, pts);
    map.set_rings(8);
    const auto converged = fractions(map, pts);
    EXPECT_LE(changed(at_t, converged), threshold) << "the image still changes after t = " << t;
    if (t >= 1) {
      map.set_rings(t - 1);
      EXPECT_GT(changed(fractions(map, pts), converged), threshold) << "t − 1 = " << t - 1 << " already gave the image";
    }
    std::printf("[ rings    ] %d² map: t = %d\n", res, t);
    chosen.push_back(t);
  }
  EXPECT_GE(chosen[0], 1) << "the coarse map needs rings";
  EXPECT_LE(chosen[1], chosen[0]) << "a finer map needs no more rings";
}

// Light on a line of floor points crossing the shadow of one sphere hanging `height` over the floor.
std::vector<float> shadow_profile(float height, float soft, float distance_b, float exponent = 1, int rings = 16) {
  const SphereWorld w(spheres({{{0, height, 0}, 0.2f}, {{3, -0.01f, 3}, 0.01f}, {{-3, -0.01f, -3}, 0.01f}}));
  ImplicitSphereShadowMap map(IssmParams{512, rings, soft, exponent, distance_b});
  map.build(w.view, directional({0, -1, 0}));
  std::vector<SurfacePoint> pts;
  for (int i = 0; i <= 400; ++i) pts.push_back({{-0.5f + static_cast<float>(i) / 400.0f, 0, 0}, {0, 1, 0}, kNoSphere});
  return fractions(map, pts);
}

int penumbra_samples(const std::vector<float>& f) {
  int n = 0;
  for (float v : f) n += v > 0.0f && v < 1.0f;
  return n;
}

TEST(IssmSoft, PenumbraWidensWithVirtualRadiusAndOccluderDistance) {
  const int narrow = penumbra_samples(shadow_profile(1.0f, 0.05f, 1.0f));
  const int wide = penumbra_samples(shadow_profile(1.0f, 0.15f, 1.0f));
  EXPECT_GT(narrow, 0);
  EXPECT_GT(wide, narrow);
  // Gaussian weight: an occluder close to the floor casts a sharper shadow than a distant one
  const int close = penumbra_samples(shadow_profile(0.3f, 0.15f, 1.0f));
  EXPECT_LT(close, wide);
  // the umbra stays: the point under the sphere's centre is fully shadowed
  EXPECT_EQ(shadow_profile(1.0f, 0.15f, 1.0f)[200], 0.0f);
}

TEST(IssmSoft, RingsGrowToReachTheWholePenumbra) {
  // s = 0.15 is about 10 texels of this map: asking for t = 0 must still find every occluder in reach
  const auto asked_none = shadow_profile(1.0f, 0.15f, 1.0f, 1, 0);
  const auto plenty = shadow_profile(1.0f, 0.15f, 1.0f, 1, 40);
  ASSERT_EQ(asked_none.size(), plenty.size());
  for (std::size_t i = 0; i < plenty.size(); ++i) EXPECT_EQ(asked_none[i], plenty[i]) << i;
  EXPECT_GT(penumbra_samples(asked_none), 0);
}

// The point of a cut sphere's kept part nearest to x, against brute force: the nearest of a fine
// lattice of kept points (the ball's inside and its surface, less the removed half-spaces) is never
// nearer than the exact point and is within the lattice's spacing of it.
TEST(CutSphere, NearestPointOfTheKeptPartAgreesWithBruteForce) {
  const Sphere s{{0.1f, -0.2f, 0.3f}, 1.0f};
  const std::vector<std::vector<ClipPlane>> cuts = {
      {{{0.3f, -0.2f, 0.3f}, normalize(Vec3{1, 0, 0})}},
      {{{0.1f, 0.2f, 0.3f}, normalize(Vec3{0.3f, 1, -0.2f})}},
      {{{0.3f, -0.2f, 0.3f}, normalize(Vec3{1, 0, 0})}, {{0.1f, -0.1f, 0.3f}, normalize(Vec3{0, 1, 0.4f})}}};
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-2.5f, 2.5f);
  for (const auto& planes_list : cuts) {
    const ClipPlanes planes(planes_list);
    const SphereClip mask = planes.classify(s.center, s.radius);
    ASSERT_NE(mask, kSphereWhole);
    ASSERT_NE(mask, kSphereRemoved);
    std::vector<Vec3> kept;
    const int n = 60;
    for (int i = 0; i <= n; ++i)
      for (int j = 0; j <= n; ++j)
        for (int k = 0; k <= n; ++k) {
          const float step = 2.0f / static_cast<float>(n);
          const Vec3 d{-1 + step * static_cast<float>(i), -1 + step * static_cast<float>(j), -1 + step * static_cast<float>(k)};
          for (const Vec3& p : {s.center + d, s.center + normalize(d) * s.radius})  // inside and on the surface
            if (length(p - s.center) <= s.radius * 1.0001f && !planes.removes(p)) kept.push_back(p);
        }
    for (int trial = 0; trial < 60; ++trial) {
      const Vec3 x = s.center + Vec3{u(rng), u(rng), u(rng)};
      const Vec3 nearest = nearest_on_cut_sphere(x, s, planes, mask);
      EXPECT_LE(length(nearest - s.center), s.radius * 1.001f);
      for (const ClipPlane& c : planes_list) EXPECT_LE(c.distance(nearest), 2e-3f);
      float brute = kInfinity;
      for (const Vec3& p : kept) brute = std::min(brute, length(x - p));
      const float exact = length(x - nearest);
      EXPECT_LE(exact, brute + 2e-3f) << "trial " << trial;
      EXPECT_GE(exact, brute - 2.0f / static_cast<float>(n) * 1.8f) << "trial " << trial;
    }
  }
}

// A sphere cut in half casts the soft fringe of its kept half: around the kept half as the whole
// sphere does, none where the removed half was, and one beside the cut face.
TEST(IssmSoft, ACutSphereCastsTheFringeOfItsKeptPart) {
  auto profile = [](bool cut) {
    ParticleSet set = spheres({{{0, 1.0f, 0}, 0.2f}, {{3, -0.01f, 3}, 0.01f}, {{-3, -0.01f, -3}, 0.01f}});
    if (cut) {
      set.clip_planes = ClipPlanes({{{0, 1.0f, 0}, {1, 0, 0}}});  // removes x > 0
      for (const Sphere& sp : set.spheres) set.clip_state.push_back(set.clip_planes.classify(sp.center, sp.radius));
    }
    const SphereWorld w(std::move(set));
    ImplicitSphereShadowMap map(IssmParams{512, 16, 0.15f, 1, 1.0f});
    map.build(w.view, directional({0, -1, 0}));
    std::vector<SurfacePoint> pts;
    for (int i = 0; i <= 400; ++i) pts.push_back({{-0.5f + static_cast<float>(i) / 400.0f, 0, 0}, {0, 1, 0}, kNoSphere});
    return fractions(map, pts);
  };
  const auto whole = profile(false), half = profile(true);
  auto at = [](const std::vector<float>& f, float x) { return f[static_cast<std::size_t>(std::lround((x + 0.5f) * 400))]; };
  EXPECT_EQ(at(half, -0.1f), 0.0f);                           // under the kept half: the umbra
  EXPECT_NEAR(at(half, -0.3f), at(whole, -0.3f), 1e-4f);      // the kept side's fringe is the whole sphere's
  EXPECT_GT(at(half, -0.3f), 0.0f);
  EXPECT_LT(at(half, -0.3f), 1.0f);
  EXPECT_GT(at(half, 0.05f), 0.0f);                           // beside the cut face: a fringe
  EXPECT_LT(at(half, 0.05f), 1.0f);
  EXPECT_EQ(at(whole, 0.1f), 0.0f);
  EXPECT_EQ(at(half, 0.25f), 1.0f);                           // where the removed half's shadow and fringe were
  EXPECT_LT(at(whole, 0.25f), 1.0f);
  for (std::size_t i = 1; i + 1 < half.size(); ++i) EXPECT_GE(half[i], whole[i] - 1e-4f) << i;  // less casts less
}

TEST(IssmSoft, VanishingVirtualRadiusGivesTheHardShadow) {
  const auto hard = shadow_profile(1.0f, 0.0f, 1.0f);
  const auto tiny = shadow_profile(1.0f, 1e-6f, 1.0f);
  ASSERT_EQ(hard.size(), tiny.size());
  for (std::size_t i = 0; i < hard.size(); ++i) EXPECT_NEAR(hard[i], tiny[i], 1e-3f);
  for (float v : hard) EXPECT_TRUE(v == 0.0f || v == 1.0f);
}

TEST(IssmPerspective, PointLightShadowsAgreeWithShadowRays) {
  const SphereWorld w(shadow_test_set());
  Light light;
  light.type = LightType::Point;
  light.position = {0.8f, 2.5f, 0.6f};
  const auto pts = facing(frame_points(w, looking_at(w.view.bounds(), test::sanitize_scale() ? 96 : 160)), light);
  RayTracedShadows exact(0, 1);
  exact.build(w.view, light);
  ImplicitSphereShadowMap map(IssmParams{1024, 1, 0, 1, 1});
  map.build(w.view, light);
  const auto ref = fractions(exact, pts);
  std::size_t shadowed = 0;
  for (float f : ref) shadowed += f < 0.5f;
  EXPECT_GT(shadowed, pts.size() / 20);  // the test has shadows to get right
  EXPECT_LT(disagreement(fractions(map, pts), ref), 0.01);
}

TEST(ParticleAo, LoneSphereIsUnoccludedAndClusterCentreIsOccluded) {
  // a lone sphere far from a cluster: nothing within reach
  ParticleSet set = random_spheres(4000, 0.04f, 5);
  const std::size_t lone = set.size();
  set.spheres.push_back({{4, 4, 4}, 0.04f});
  set.colors.push_back(pack_rgba8(Rgb(1)));
  const SphereWorld w(std::move(set));
  AmbientSettings s;
  s.params.set("max_distance", 0.1f);  // of the longest side (4.5): 0.45, less than the gap
  ParticleAmbientOcclusion ao(s.params);
  ao.build(w.view);
  std::vector<SurfacePoint> on_lone, in_cluster;
  for (int i = 0; i < 64; ++i) {
    const float z = 1.0f - 2.0f * (static_cast<float>(i) + 0.5f) / 64.0f;
    const float r = std::sqrt(1 - z * z), phi = static_cast<float>(i) * 2.39996323f;
    const Vec3 n{r * std::cos(phi), r * std::sin(phi), z};
    on_lone.push_back({Vec3{4, 4, 4} + n * 0.04f, n, static_cast<std::uint32_t>(lone)});
    in_cluster.push_back({n * 0.01f, n, kNoSphere});
  }
  std::vector<float> a(64), b(64);
  a = ambient_of(ao, on_lone);
  b = ambient_of(ao, in_cluster);
  double mean_a = 0, mean_b = 0;
  for (int i = 0; i < 64; ++i) { mean_a += a[static_cast<std::size_t>(i)] / 64; mean_b += b[static_cast<std::size_t>(i)] / 64; }
  EXPECT_GT(mean_a, 0.97);
  EXPECT_LT(mean_b, 0.3);
}

TEST(ParticleAo, AFloorOutsideTheDensityGridIsOccludedByTheClusterAboveIt) {
  const SphereWorld w(random_spheres(1500, 0.04f, 4));
  AmbientSettings s;
  s.params.set("rays", 1024);
  ParticleAmbientOcclusion approx(s.params);
  approx.build(w.view);
  RayTracedAmbientOcclusion exact(static_cast<float>(param_number(TechniqueFamily::Ambient, s.params, "max_distance")), static_cast<int>(param_integer(TechniqueFamily::Ambient, s.params, "rays")));
  exact.build(w.view);
  // floor points under the cluster (outside its box) and far to the side of it
  const std::vector<SurfacePoint> pts{{{0, -0.6f, 0}, {0, 1, 0}, kNoSphere}, {{0.2f, -0.6f, -0.1f}, {0, 1, 0}, kNoSphere},
                                      {{3, -0.6f, 3}, {0, 1, 0}, kNoSphere}};
  std::vector<float> a(3), b(3);
  a = ambient_of(approx, pts);
  b = ambient_of(exact, pts);
  EXPECT_LT(a[0], 0.8f);
  EXPECT_NEAR(a[0], b[0], 0.15f);
  EXPECT_NEAR(a[1], b[1], 0.15f);
  EXPECT_EQ(a[2], 1.0f);
}

TEST(ParticleAo, AFloorsOcclusionHasNoEdgeWhereItLeavesTheGridsFootprint) {
  const SphereWorld w(random_spheres(3000, 0.025f, 3));
  ParticleAmbientOcclusion ao(TechniqueParams{});
  ao.build(w.view);
  // floor points on a line from under the cluster to well outside its box (which ends near x = 0.54)
  std::vector<SurfacePoint> pts;
  for (int i = 0; i <= 120; ++i) pts.push_back({{0.2f + 0.006f * static_cast<float>(i), -0.6f, 0.1f}, {0, 1, 0}, kNoSphere});
  std::vector<float> a(pts.size());
  a = ambient_of(ao, pts);
  float largest_step = 0;
  for (std::size_t i = 1; i < a.size(); ++i) largest_step = std::max(largest_step, std::abs(a[i] - a[i - 1]));
  EXPECT_LT(largest_step, 0.02f);
  EXPECT_LT(a.front(), a.back());  // darker under the cluster than beside it
}

// Particle AO (cones through a density pyramid) against Monte-Carlo AO with the same reach, over the
// visible surface points of a small dense cluster. The reference b_i estimates the true AO v_i with N
// cosine-weighted rays: unbiased, variance σ_i² ≤ v_i(1 − v_i)/N (binomial; the rotated lattice only
// lowers it), estimated by b_i(1 − b_i)/N; the rotations are independent per point. So:
//  - noise-free RMS error: E[(a − b)²] = E[(a − v)²] + E[σ²], hence the approximation's own RMS error
//    is estimated by √(mean (a − b)² − mean σ²); its standard error is small (thousands of points) and
//    it must be ≤ 0.15, the budget of this approximation on this soup of overlapping spheres (40 %
//    filled; its cones see it as a little more opaque than it is, docs/techniques/issm.md);
//  - bias: |mean a − mean b| ≤ 0.12 (same budget) + 4·SE(mean b), SE(mean b) = √(Σ σ_i²)/n;
//  - correlation: Pearson r(a, b) across the image; MC noise caps what even a perfect AO can reach at
//    r_max = √(1 − mean σ² / var b) (attenuation), and we ask r ≥ 0.8·r_max (the AO explains ≥ 64 % of
//    the true AO's variance). A constant AO (or none) has
//    r = 0, and its noise-free RMS error is the true AO's spread √(var b − mean σ²): asserted to be
//    above the RMS budget too, so a constant at the right mean fails both checks.
// Measured (Release, N = 1024, 2894 points): means 0.548 / 0.640 (SE 0.0002), noise-free RMS 0.122, MC
// σ 0.0125, r 0.956 of r_max 0.999, a constant AO's RMS 0.266.
// The cone cache: every sphere its entry when that fits, else entries from a pool for the spheres
// stored first; a full pool stores no more; cones > 64 are not cached.
TEST(SphereConeCache, EntriesForEverySphereOrFromAPool) {
  SphereConeCache all;
  all.reset(100, 8, 100 * 16);
  EXPECT_TRUE(all.enabled() && all.every_sphere());
  std::uint8_t q = 0;
  EXPECT_FALSE(all.get(7, 3, q));
  all.put(7, 3, 200);
  ASSERT_TRUE(all.get(7, 3, q));
  EXPECT_EQ(q, 200);
  EXPECT_FALSE(all.get(7, 4, q));
  all.put(7, 5, 17);
  std::uint8_t every[SphereConeCache::kMaxCones] = {};
  EXPECT_EQ(all.get_all(7, every), (std::uint64_t{1} << 3) | (std::uint64_t{1} << 5));
  EXPECT_EQ(every[3], 200);
  EXPECT_EQ(every[5], 17);
  EXPECT_EQ(all.get_all(8, every), 0u);
  EXPECT_EQ(all.memory_bytes(), 100u * 16);

  // cones share 64-bit words, eight to a word: a store leaves its neighbours, unstored cones read 0
  SphereConeCache wide;
  wide.reset(4, 12, 4 * 24);
  EXPECT_TRUE(wide.enabled() && wide.every_sphere());
  wide.put(2, 9, 255);
  wide.put(2, 10, 1);
  wide.put(2, 0, 7);
  std::fill(std::begin(every), std::end(every), std::uint8_t{99});
  EXPECT_EQ(wide.get_all(2, every), (std::uint64_t{1} << 0) | (std::uint64_t{1} << 9) | (std::uint64_t{1} << 10));
  const std::uint8_t expected[12] = {7, 0, 0, 0, 0, 0, 0, 0, 0, 255, 1, 0};
  for (std::size_t c = 0; c < 12; ++c) EXPECT_EQ(every[c], expected[c]) << "cone " << c;
  ASSERT_TRUE(wide.get(2, 9, q));
  EXPECT_EQ(q, 255);

  SphereConeCache pooled;
  pooled.reset(1000, 8, 1000 * 4 + 10 * 16);  // the sphere table and 10 entries
  EXPECT_TRUE(pooled.enabled() && !pooled.every_sphere());
  for (std::uint32_t s = 0; s < 12; ++s)
    for (std::size_t c = 0; c < 8; ++c) pooled.put(500 + s, c, static_cast<std::uint8_t>(s * 8 + c));
  for (std::uint32_t s = 0; s < 12; ++s) {
    SCOPED_TRACE(s);
    for (std::size_t c = 0; c < 8; ++c) {
      const bool stored = pooled.get(500 + s, c, q);
      EXPECT_EQ(stored, s < 10);
      if (stored) {
        EXPECT_EQ(q, s * 8 + c);
      }
    }
  }
  EXPECT_FALSE(pooled.get(3, 0, q));
  EXPECT_EQ(pooled.get_all(503, every), 0xFFu);
  EXPECT_EQ(every[6], 3 * 8 + 6);
  EXPECT_EQ(pooled.get_all(511, every), 0u);  // the pool was full
  EXPECT_EQ(pooled.entries_used(), 10u);
  EXPECT_EQ(pooled.memory_bytes(), 1000u * 4 + 10 * 16);

  SphereConeCache none;
  none.reset(1000, 65, std::size_t{1} << 30);
  EXPECT_FALSE(none.enabled());
  none.put(1, 1, 9);
  EXPECT_FALSE(none.get(1, 1, q));
  none.reset(1000, 8, 1000 * 4);  // not even the table fits
  EXPECT_FALSE(none.enabled());
}

// Threads storing the same spheres at once give each sphere one entry and lose no cone.
TEST(SphereConeCache, ConcurrentStoresKeepEveryCone) {
  constexpr std::uint32_t kSpheres = 4000;
  constexpr std::size_t kCones = 32;
  SphereConeCache pooled;
  pooled.reset(kSpheres, kCones, kSpheres * (kCones + 8) - 1);  // just short of an entry for every sphere
  ASSERT_FALSE(pooled.every_sphere());
  const std::size_t capacity = (kSpheres * (kCones + 8) - 1 - kSpheres * 4) / (kCones + 8);  // 3,599
  // every (sphere, cone) stored by four tasks at once, in an order that differs per task
  parallel_for(std::size_t{4} * kSpheres * kCones, [&](std::size_t b, std::size_t e) {
    for (std::size_t i = b; i < e; ++i) {
      const std::size_t k = i % (std::size_t{kSpheres} * kCones);
      const auto s = static_cast<std::uint32_t>(((k / kCones) * 2654435761u) % kSpheres);
      const std::size_t c = k % kCones;
      pooled.put(s, c, static_cast<std::uint8_t>((s + c) & 0xFF));
    }
  }, 64);
  std::uint8_t q = 0;
  std::size_t stored = 0;
  for (std::uint32_t s = 0; s < kSpheres; ++s)
    for (std::size_t c = 0; c < kCones; ++c)
      if (pooled.get(s, c, q)) {
        ++stored;
        EXPECT_EQ(q, (s + c) & 0xFF);
      }
  // the pool holds 90 % of the spheres, each entry one sphere's: a store that meets a sphere being
  // claimed by another thread is skipped, and the four stores of each cone make up for it
  EXPECT_EQ(pooled.entries_used(), capacity);
  EXPECT_EQ(stored, capacity * kCones);
}

// The cache changes no result: AO with an entry for every sphere, with a pool smaller than the
// spheres, and with no cache are the same, on a first frame and on one that reads the cache.
TEST(ParticleAo, TheConeCacheChangesNoResult) {
  const SphereWorld w(random_spheres(600, 0.05f, 4));
  const auto pts = frame_points(w, looking_at(w.view.bounds(), 48));
  AmbientSettings s;
  s.params.set("max_distance", 0.3f);
  const std::size_t cones = 2 * static_cast<std::size_t>(static_cast<int>(param_integer(TechniqueFamily::Ambient, s.params, "directions")));
  ParticleAmbientOcclusion all(s.params), pooled(s.params, 600 * 4 + 150 * (cones + 8)), uncached(s.params, 0);
  for (ParticleAmbientOcclusion* ao : {&all, &pooled, &uncached}) ao->build(w.view);
  for (int frame = 0; frame < 2; ++frame) {
    SCOPED_TRACE(frame);
    const std::vector<float> a = ambient_of(all, pts), b = ambient_of(pooled, pts), c = ambient_of(uncached, pts);
    ASSERT_GT(a.size(), 500u);
    EXPECT_EQ(a, b);
    EXPECT_EQ(a, c);
  }
  EXPECT_GT(pooled.memory_bytes(), uncached.memory_bytes());
}

// ambient.reuse (paper 003: the AO updated, not rebuilt, when atoms move a little): a rebuild keeps a
// sphere's cones while it moved less than `reuse` density cells, and the result stays near a fresh
// build's; spheres that moved further, or matter that moved more than that anywhere, are traced anew,
// exactly as a fresh build traces them.
TEST(ParticleAo, KeptConesFollowSmallMovesAndLargeMovesAreTracedAnew) {
  const ParticleSet start = random_spheres(600, 0.05f, 4);
  // every sphere moved by `cells` density cells (the grid's cell: the box's side / 64) in its own direction
  const auto moved = [&](float cells) {
    ParticleSet p = start;
    const float cell = 1.0f / 64.0f;
    for (std::size_t i = 0; i < p.size(); ++i) {
      const Vec3 d = normalize(Vec3{uniform_float(99, i, 0) - 0.5f, uniform_float(99, i, 1) - 0.5f, uniform_float(99, i, 2) - 0.5f});
      p.spheres[i].center = p.spheres[i].center + d * (cells * cell);
    }
    return p;
  };
  AmbientSettings s;
  s.params.set("max_distance", 0.3f);
  AmbientSettings keeping = s;
  keeping.params.set("reuse", 1.0);
  ParticleAmbientOcclusion kept(keeping.params);
  ASSERT_TRUE(kept.keeps_state_across_builds());
  EXPECT_FALSE(ParticleAmbientOcclusion(s.params).keeps_state_across_builds());
  const auto fresh = [&](const SphereWorld& w, const std::vector<SurfacePoint>& pts) {
    ParticleAmbientOcclusion ao(s.params);
    ao.build(w.view);
    return ambient_of(ao, pts);
  };

  const SphereWorld w0(start);
  const auto pts0 = frame_points(w0, looking_at(w0.view.bounds(), 48));
  kept.build(w0.view);
  EXPECT_EQ(kept.kept_from_last_build(), 0u);
  EXPECT_EQ(ambient_of(kept, pts0), fresh(w0, pts0));
  kept.build(w0.view);  // nothing moved: every cone kept, the same values
  EXPECT_EQ(kept.kept_from_last_build(), start.size());
  EXPECT_EQ(ambient_of(kept, pts0), fresh(w0, pts0));

  const SphereWorld w1(moved(0.2f));  // a little: kept, within a few quantisation steps of a fresh build
  const auto pts1 = frame_points(w1, looking_at(w1.view.bounds(), 48));
  kept.build(w1.view);
  EXPECT_EQ(kept.kept_from_last_build(), start.size());
  const std::vector<float> a = ambient_of(kept, pts1), b = fresh(w1, pts1);
  ASSERT_GT(a.size(), 500u);
  double worst = 0, sum = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    worst = std::max(worst, static_cast<double>(std::abs(a[i] - b[i])));
    sum += std::abs(a[i] - b[i]);
  }
  EXPECT_LT(worst, 0.05);
  EXPECT_LT(sum / static_cast<double>(a.size()), 0.005);

  const SphereWorld w2(moved(2.0f));  // beyond `reuse`: every sphere traced anew, as a fresh build does
  const auto pts2 = frame_points(w2, looking_at(w2.view.bounds(), 48));
  kept.build(w2.view);
  EXPECT_EQ(kept.kept_from_last_build(), 0u);
  EXPECT_EQ(ambient_of(kept, pts2), fresh(w2, pts2));
}

// A sphere that moved further than `reuse` is traced anew while the others keep their cones (reuse 8:
// no opacity change drops them all).
TEST(ParticleAo, OnlyTheSpheresThatMovedAreTracedAnew) {
  ParticleSet set = random_spheres(300, 0.02f, 5);
  AmbientSettings s;
  s.params.set("reuse", 8.0);
  ParticleAmbientOcclusion ao(s.params);
  const SphereWorld w0(set);
  ao.build(w0.view);
  (void)ambient_of(ao, frame_points(w0, looking_at(w0.view.bounds(), 32)));
  // two spheres well inside the box (it stays as it was): one moves 13+ cells inwards, one grows by 11
  const auto inside = [](const Vec3& c, float r) { return std::abs(c.x) < r && std::abs(c.y) < r && std::abs(c.z) < r; };
  std::size_t moving = set.size(), growing = set.size();
  for (std::size_t i = 0; i < set.size(); ++i) {
    const Vec3 c = set.spheres[i].center;
    if (moving == set.size() && inside(c, 0.4f) && length(c) > 0.3f) moving = i;
    else if (growing == set.size() && inside(c, 0.25f)) growing = i;
  }
  ASSERT_LT(moving, set.size());
  ASSERT_LT(growing, set.size());
  set.spheres[moving].center = set.spheres[moving].center * 0.2f;
  set.spheres[growing].radius = 0.2f;
  const SphereWorld w1(set);
  ASSERT_EQ(w1.view.bounds().lo, w0.view.bounds().lo);
  ao.build(w1.view);
  EXPECT_EQ(ao.kept_from_last_build(), set.size() - 2);
}

// Matter that moved more than `reuse` cells drops every kept cone, even when no sphere alone moved
// that far: two coincident spheres each moved 0.45 cells (reuse 0.5) change the filled fraction of the
// cells at their edge by 0.9; one sphere moved as far changes it by 0.45 and its cones are kept.
TEST(ParticleAo, MatterMovedBeyondReuseDropsEveryCone) {
  const auto scene_with = [](int middle, float shift) {
    ParticleSet p;
    for (int k = 0; k < 8; ++k)  // the box, held still by eight spheres at its corners
      p.spheres.push_back({{k & 1 ? 0.5f : -0.5f, k & 2 ? 0.5f : -0.5f, k & 4 ? 0.5f : -0.5f}, 0.05f});
    for (int i = 0; i < middle; ++i) p.spheres.push_back({{shift, 0, 0}, 0.1f});
    p.colors.assign(p.spheres.size(), pack_rgba8(Rgb(0.8f)));
    return p;
  };
  const float cell = 1.1f / 64.0f;  // the box's side, corner spheres included, over the grid
  for (const int middle : {1, 2}) {
    SCOPED_TRACE(middle);
    AmbientSettings s;
    s.params.set("reuse", 0.5);
    ParticleAmbientOcclusion ao(s.params);
    const SphereWorld w0(scene_with(middle, 0));
    ao.build(w0.view);
    const SphereWorld w1(scene_with(middle, 0.45f * cell));
    ao.build(w1.view);
    EXPECT_EQ(ao.kept_from_last_build(), middle == 1 ? w1.particles.size() : 0u);
  }
}

// forget() drops one sphere's cones and leaves the others', with an entry for every sphere and pooled.
TEST(SphereConeCache, ForgettingASphereLeavesTheOthers) {
  for (const std::size_t bytes : {std::size_t{1} << 20, std::size_t{100} * 4 + 20 * 16}) {
    SphereConeCache cache;
    cache.reset(100, 8, bytes);
    ASSERT_TRUE(cache.enabled());
    for (std::uint32_t s = 0; s < 10; ++s)
      for (std::size_t c = 0; c < 8; ++c) cache.put(s, c, static_cast<std::uint8_t>(s * 8 + c + 1));
    cache.forget(3);
    std::uint8_t q[8] = {};
    EXPECT_EQ(cache.get_all(3, q), 0u);
    for (const std::uint8_t v : q) EXPECT_EQ(v, 0);
    EXPECT_EQ(cache.get_all(4, q), 0xFFu);
    EXPECT_EQ(q[5], 4 * 8 + 5 + 1);
    cache.put(3, 2, 77);  // a sphere forgotten is stored again
    EXPECT_EQ(cache.get_all(3, q), 0x4u);
    EXPECT_EQ(q[2], 77);
    EXPECT_TRUE(cache.laid_out_for(100, 8, bytes));
    EXPECT_FALSE(cache.laid_out_for(101, 8, bytes));
  }
}

TEST(ParticleAo, AgreesWithMonteCarloAmbientOcclusionOnASmallCluster) {
  const SphereWorld w(random_spheres(800, 0.05f, 9));
  const auto pts = frame_points(w, looking_at(w.view.bounds(), test::sanitize_scale() ? 40 : 64));
  AmbientSettings s;
  s.params.set("max_distance", 0.3f);
  s.params.set("rays", test::sanitize_scale() ? 256 : 1024);
  ParticleAmbientOcclusion approx(s.params);
  approx.build(w.view);
  RayTracedAmbientOcclusion exact(static_cast<float>(param_number(TechniqueFamily::Ambient, s.params, "max_distance")), static_cast<int>(param_integer(TechniqueFamily::Ambient, s.params, "rays")));
  exact.build(w.view);
  std::vector<float> a(pts.size()), b(pts.size());
  a = ambient_of(approx, pts);
  b = ambient_of(exact, pts);
  const double n = static_cast<double>(pts.size());
  ASSERT_GT(n, 500);
  double mean_a = 0, mean_b = 0, sq = 0, noise = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    mean_a += a[i] / n;
    mean_b += b[i] / n;
    sq += (a[i] - b[i]) * (a[i] - b[i]) / n;
    noise += b[i] * (1.0 - b[i]) / static_cast<int>(param_integer(TechniqueFamily::Ambient, s.params, "rays")) / n;  // mean σ²
  }
  double var_a = 0, var_b = 0, cov = 0;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    var_a += (a[i] - mean_a) * (a[i] - mean_a) / n;
    var_b += (b[i] - mean_b) * (b[i] - mean_b) / n;
    cov += (a[i] - mean_a) * (b[i] - mean_b) / n;
  }
  const double rms = std::sqrt(std::max(0.0, sq - noise));
  const double corr = var_a > 0 && var_b > 0 ? cov / std::sqrt(var_a * var_b) : 0.0;
  const double corr_max = std::sqrt(1 - noise / var_b);
  const double se_mean = std::sqrt(noise * n) / n;
  const double spread = std::sqrt(std::max(0.0, var_b - noise));  // noise-free RMS error of a constant AO
  std::printf("[ ao       ] %zu points, N = %d: means %.4f / %.4f (SE %.4f), noise-free RMS %.4f, MC σ %.4f, "
              "r %.3f (max %.3f), constant AO's RMS %.4f\n",
              pts.size(), static_cast<int>(param_integer(TechniqueFamily::Ambient, s.params, "rays")), mean_a, mean_b, se_mean, rms, std::sqrt(noise), corr, corr_max, spread);
  const double rms_budget = 0.15, bias_budget = 0.12;
  EXPECT_LT(rms, rms_budget);
  EXPECT_NEAR(mean_a, mean_b, bias_budget + 4 * se_mean);
  EXPECT_GT(corr, 0.8 * corr_max) << "the AO must follow the reference across the image";
  EXPECT_GT(spread, rms_budget + 0.02) << "the scene's AO varies enough that a constant fails the RMS check";
}

}  // namespace
}  // namespace penumbra

namespace penumbra {
namespace {

// A sphere in front of a translucent slab volume and one behind it, seen along -z.
Image composite_frame(bool with_volume) {
  nlohmann::json j = nlohmann::json::parse(R"({
    "particles": [ { "procedural": { "name": "random-spheres", "count": 1, "radius": 0.001, "seed": 1 } } ],
    "camera": { "eye": [0, 0, 3], "target": [0, 0, 0], "fov_deg": 40, "width": 48, "height": 48 },
    "lights": [ { "type": "directional", "direction": [0, 0, -1] } ],
    "shadows": { "technique": "none" },
    "background": [0, 0, 0]
  })");
  j["particles"][0]["origin"] = {-0.2, 0.0, 0.9};  // in front of the slab (the slab spans z in [-0.5, 0.5])
  j["particles"].push_back({{"procedural", {{"name", "random-spheres"}, {"count", 1}, {"radius", 0.001}, {"seed", 2}}}, {"origin", {0.2, 0.0, -0.9}}});
  if (with_volume)
    j["volumes"] = nlohmann::json::array({{{"procedural", {{"name", "slab"}, {"size", 16}, {"thickness", 2.0}}},
                                           {"transfer_function", test::constant_tf(0.05, 1, 1, 1)}, {"step", 0.5}}});
  Scene s = build_scene(j, "");
  // make the two spheres large enough to cover pixels
  auto set = std::make_shared<ParticleSet>();
  for (const auto& p : s.particles) {
    set->spheres.push_back({p.set->spheres[0].center, 0.15f});
    set->colors.push_back(pack_rgba8(Rgb(0.9f, 0.2f, 0.2f)));
  }
  ParticleObject object;
  object.set = set;
  object.source = "test";
  s.particles = {object};
  return Renderer(s).render().image;
}

TEST(ParticleScene, VolumesAreCompositedByDepthWithTheSpheres) {
  const Image spheres = composite_frame(false);
  const Image both = composite_frame(true);
  test::FailureImages keep;
  keep.add("with_volume", both, spheres);
  // pixel columns of the front (x < 0) and back (x > 0) sphere, on the middle row
  const int y = 24;
  int front_x = -1, back_x = -1;
  for (int x = 0; x < 48; ++x) {
    if (spheres.at(x, y).r > 0.05f) (x < 24 ? front_x : back_x) = x;
  }
  ASSERT_GE(front_x, 0);
  ASSERT_GE(back_x, 0);
  // the sphere in front of the slab is untouched by it; the one behind is seen through the slab
  const Rgb f0 = spheres.at(front_x, y), f1 = both.at(front_x, y);
  EXPECT_NEAR(f0.r, f1.r, 1e-6f);
  const Rgb b0 = spheres.at(back_x, y), b1 = both.at(back_x, y);
  EXPECT_GT(std::abs(b0.r - b1.r) + std::abs(b0.g - b1.g), 0.02f);
}

}  // namespace
}  // namespace penumbra
