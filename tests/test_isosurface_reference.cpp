// Tests of the exact isosurface reference and the marching-cubes baseline (paper 002's comparisons):
// the trilinear root against dense sampling, the ray caster against the analytic sphere and against
// a walk over every cell (brick skipping drops nothing), exact shadow rays, the marching-cubes mesh
// (on the surface, closed, the sphere's area, gradient normals), its rasterisation against the ray
// caster and a crack-free fill, and determinism across thread counts.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>
#include <map>
#include <random>
#include <tuple>
#include <vector>

#include "penumbra/core/parallel.h"
#include "penumbra/geometry/grid_tree.h"
#include "penumbra/geometry/isosurface_raycaster.h"
#include "penumbra/isosurface/marching_cubes.h"
#include "penumbra/geometry/trilinear_root.h"
#include "isosurface_test_util.h"
#include "test_scenes.h"

using namespace penumbra;
using penumbra::test::field_volume;

namespace {

const Vec3 kCentre{0.05f, -0.03f, 0.02f};
constexpr float kRadius = 0.6137f;

// The sampled distance field of a sphere: r - |p - c|, inside >= 0.
Volume sphere_volume(int n) {
  return field_volume(n, [](const Vec3& p) { return kRadius - length(p - kCentre); });
}

// Smooth blobs in one corner of the volume, one of them large and solid (bricks wholly inside), the
// rest of the volume empty (bricks wholly outside): every level of the tree prunes something. None
// reaches the border. As uint8 (value * 200), many voxels equal the isovalue exactly.
Volume blobs_volume(int n, ScalarType type) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0, 1);
  std::vector<std::array<float, 5>> blobs;  // centre, radius, height
  blobs.push_back({-0.35f, -0.3f, -0.3f, 0.35f, 2.5f});
  for (int b = 0; b < 24; ++b)
    blobs.push_back({u(rng) - 0.6f, u(rng) - 0.6f, u(rng) - 0.6f, 0.05f + 0.12f * u(rng), 0.4f + u(rng)});
  const float scale = type == ScalarType::UInt8 ? 200.0f : 1.0f;
  return field_volume(n, [&](const Vec3& p) {
    float f = 0;
    for (const auto& b : blobs) {
      const Vec3 d = p - Vec3{b[0], b[1], b[2]};
      f += b[4] * std::exp(-dot(d, d) / (b[3] * b[3]));
    }
    return type == ScalarType::UInt8 ? std::round(std::min(f, 1.2f) * scale) : f;
  }, type);
}

Camera reference_camera(int size, Vec3 eye = {1.3f, 0.9f, 1.8f}) { return test::camera_at(size, eye); }

int image_size(int size) { return test::sanitize_scale() ? size / 2 : size; }

// The trilinear interpolant of a single cell at local coordinates (x, y, z), in double.
double trilinear(const CornerValues& c, double x, double y, double z) {
  double f = 0;
  for (int n = 0; n < 8; ++n)
    f += c[static_cast<std::size_t>(n)] * ((n & 1) ? x : 1 - x) * ((n & 2) ? y : 1 - y) * ((n & 4) ? z : 1 - z);
  return f;
}

// Reference walk: every cell the ray passes through, from the sorted crossings of all grid planes
// (no tree, no DDA), with the same state carried from cell to cell as the ray caster.
float every_cell_first_hit(const Volume& v, float iso, const Ray& ray) {
  const auto& d = v.dims();
  const Box3 box{v.origin(), v.origin() + Vec3{static_cast<float>(d[0] - 1), static_cast<float>(d[1] - 1), static_cast<float>(d[2] - 1)} * v.spacing()};
  float t0, t1;
  if (!box.clip(ray, t0, t1)) return kInfinity;
  std::vector<float> ts{t0, t1};
  for (int a = 0; a < 3; ++a) {
    if (ray.direction[a] == 0) continue;
    for (int i = 0; i < d[static_cast<std::size_t>(a)]; ++i) {
      const float t = (v.origin()[a] + static_cast<float>(i) * v.spacing()[a] - ray.origin[a]) / ray.direction[a];
      if (t > t0 && t < t1) ts.push_back(t);
    }
  }
  std::sort(ts.begin(), ts.end());
  const GridRay grid(v, ray);
  int state = -1;
  for (std::size_t s = 0; s + 1 < ts.size(); ++s) {
    const Vec3 mid = v.to_voxel(ray.at(0.5f * (ts[s] + ts[s + 1])));
    std::array<int, 3> c;
    for (int a = 0; a < 3; ++a) c[static_cast<std::size_t>(a)] = std::clamp(static_cast<int>(std::floor(mid[a])), 0, d[static_cast<std::size_t>(a)] - 2);
    CornerValues corners;
    float lo = kInfinity, hi = -kInfinity;
    for (int n = 0; n < 8; ++n) {
      corners[static_cast<std::size_t>(n)] = v.value(c[0] + (n & 1), c[1] + ((n >> 1) & 1), c[2] + (n >> 2));
      lo = std::min(lo, corners[static_cast<std::size_t>(n)]);
      hi = std::max(hi, corners[static_cast<std::size_t>(n)]);
    }
    if (!range_straddles(lo, hi, iso)) {
      const int inside = lo >= iso ? 1 : 0;
      if (state >= 0 && state != inside) return ts[s];
      state = inside;
      continue;
    }
    if (state < 0) state = inside_at(corners, c, iso, grid, ts[s]) ? 1 : 0;
    const float t = first_state_change(corners, c, iso, grid, ts[s], ts[s + 1], state == 1);
    if (t < kInfinity) return t;
  }
  return kInfinity;
}

bool identical(const IsoPoints& a, const IsoPoints& b) {
  return a.size() == b.size() && (a.empty() || std::memcmp(a.data(), b.data(), a.size() * sizeof(IsoPoint)) == 0);
}

double mesh_area(const TriangleMesh& m) {
  double area = 0;
  for (std::size_t t = 0; t < m.triangles(); ++t)
    area += 0.5 * length(cross(m.vertices[3 * t + 1] - m.vertices[3 * t], m.vertices[3 * t + 2] - m.vertices[3 * t]));
  return area;
}

// Each directed edge of a closed, consistently wound mesh appears once, and its reverse once.
// Vertices are compared by their bits: marching cubes computes a shared vertex identically.
std::size_t unmatched_edges(const TriangleMesh& m) {
  using Key = std::array<float, 6>;
  std::map<Key, int> edges;
  for (std::size_t t = 0; t < m.triangles(); ++t)
    for (std::size_t e = 0; e < 3; ++e) {
      const Vec3 &a = m.vertices[3 * t + e], &b = m.vertices[3 * t + (e + 1) % 3];
      ++edges[{a.x, a.y, a.z, b.x, b.y, b.z}];
    }
  std::size_t bad = 0;
  for (const auto& [k, n] : edges) {
    const auto reverse = edges.find({k[3], k[4], k[5], k[0], k[1], k[2]});
    if (n != 1 || reverse == edges.end() || reverse->second != 1) ++bad;
  }
  return bad;
}

}  // namespace

TEST(TrilinearRoot, FirstCrossingMatchesDenseSampling) {
  // One cell of random corners, spacing and origin; random rays through it. The first change of the
  // inside state among 10^4 samples must lie within one sample step of the root found.
  std::mt19937 rng(42);
  std::uniform_real_distribution<float> u(0, 1);
  const int cases = test::sanitize_scale() ? 300 : 3000;
  constexpr int kSamples = 10000;
  int crossings = 0, several = 0;
  for (int c = 0; c < cases; ++c) {
    Volume v(ScalarType::Float32, {2, 2, 2}, {0.3f + 2 * u(rng), 0.3f + 2 * u(rng), 0.3f + 2 * u(rng)},
             {10 * u(rng) - 5, 10 * u(rng) - 5, 10 * u(rng) - 5});
    CornerValues corners;
    for (int n = 0; n < 8; ++n) {
      corners[static_cast<std::size_t>(n)] = 2 * u(rng) - 1;
      v.set_value(static_cast<std::size_t>(n), corners[static_cast<std::size_t>(n)]);
    }
    const float iso = 0.6f * u(rng) - 0.3f;
    const Box3 box = v.bounds();
    const Vec3 a = box.lo + Vec3{u(rng), u(rng), u(rng)} * box.extent();
    const Vec3 b = box.lo + Vec3{u(rng), u(rng), u(rng)} * box.extent();
    const Vec3 dir = normalize(b - a);
    const Ray ray{a - dir * (3 * u(rng)), dir};
    float t0, t1;
    ASSERT_TRUE(box.clip(ray, t0, t1));
    const float t = first_crossing_in_cell(v, {0, 0, 0}, iso, ray, t0, t1);

    const auto g = [&](double s) {
      const Vec3 p = ray.at(static_cast<float>(s));
      return trilinear(corners, (static_cast<double>(p.x) - box.lo.x) / v.spacing().x,
                       (static_cast<double>(p.y) - box.lo.y) / v.spacing().y,
                       (static_cast<double>(p.z) - box.lo.z) / v.spacing().z) - iso;
    };
    const double step = (static_cast<double>(t1) - t0) / kSamples;
    const bool start = g(t0) >= 0;
    int first = -1, changes = 0;
    bool state = start;
    for (int k = 1; k <= kSamples; ++k) {
      const bool s = g(t0 + k * step) >= 0;
      if (s != state) {
        if (first < 0) first = k;
        ++changes;
        state = s;
      }
    }
    const double tol = 1e-4 * (static_cast<double>(t1) - t0) + 1e-5;
    if (first > 0) {
      ++crossings;
      several += changes > 1;
      ASSERT_LT(t, kInfinity) << "missed a crossing, case " << c;
      ASSERT_LE(t, t0 + first * step + tol) << "case " << c;
      ASSERT_LT(std::abs(g(t)), 1e-4) << "not a root, case " << c;  // earlier than the samples: a narrow excursion
    } else if (t < kInfinity) {
      ASSERT_LT(std::abs(g(t)), 1e-4) << "a crossing where sampling sees none is a narrow excursion, case " << c;
    }
  }
  EXPECT_GT(crossings, cases / 5);  // the cases exercise crossings...
  EXPECT_GT(several, 5);            // ...and rays that cross more than once in a cell
}

TEST(TrilinearRoot, StateGivenByTheCallerReportsACrossingAtTheStart) {
  Volume v(ScalarType::Float32, {2, 2, 2});
  for (std::size_t n = 0; n < 8; ++n) v.set_value(n, (n & 1) ? 1.0f : 0.0f);  // f = x
  const Ray ray{{-1, 0.5f, 0.5f}, {1, 0, 0}};
  const GridRay grid(v, ray);
  CornerValues c{0, 1, 0, 1, 0, 1, 0, 1};
  EXPECT_NEAR(first_crossing_in_cell(v, {0, 0, 0}, 0.25f, ray, 1, 2), 1.25f, 1e-6f);
  EXPECT_EQ(first_state_change(c, {0, 0, 0}, 0.25f, grid, 1.5f, 2, false), 1.5f);  // already inside at 1.5
  EXPECT_EQ(first_state_change(c, {0, 0, 0}, 0.25f, grid, 1.5f, 2, true), kInfinity);
  // On the surface at the start (f == iso is inside): the crossing is where the ray leaves.
  const Ray back{{2, 0.5f, 0.5f}, {-1, 0, 0}};
  EXPECT_NEAR(first_crossing_in_cell(v, {0, 0, 0}, 0.25f, back, 1, 2), 1.75f, 1e-6f);
  EXPECT_EQ(first_crossing_in_cell(v, {0, 0, 0}, 0.25f, ray, 1.25f, 2), kInfinity);  // on it, going in
}

TEST(IsosurfaceRaycaster, SphereMatchesTheAnalyticIntersection) {
  const Volume v = sphere_volume(48);
  const GridTree tree(v);
  const float h = v.spacing().x;
  const Camera cam = reference_camera(image_size(96));
  const IsoPoints points = IsosurfaceRaycaster(tree, 0.0f).render(cam);
  std::vector<const IsoPoint*> at(static_cast<std::size_t>(cam.width * cam.height), nullptr);
  for (const IsoPoint& p : points) at[p.pixel] = &p;
  const PrimaryRays rays(cam);
  int hits = 0;
  for (int y = 0; y < cam.height; ++y)
    for (int x = 0; x < cam.width; ++x) {
      const Ray r = rays.ray(x, y);
      const Vec3 oc = r.origin - kCentre;
      const float along = -dot(oc, r.direction);
      const float miss = length(oc + r.direction * along);  // closest distance of the ray to the centre
      const IsoPoint* p = at[static_cast<std::size_t>(y * cam.width + x)];
      if (miss > kRadius + h) {
        EXPECT_EQ(p, nullptr) << x << " " << y;
      } else if (miss < kRadius - h) {
        ASSERT_NE(p, nullptr) << x << " " << y;
        ++hits;
        if (miss > 0.9f * kRadius) continue;  // grazing: the depth error grows as 1 / cos
        const float exact = along - std::sqrt(kRadius * kRadius - miss * miss);
        EXPECT_NEAR(p->distance, exact, 0.25f * h);
        EXPECT_GT(dot(p->normal, normalize(p->position - kCentre)), 0.99f);
        EXPECT_LT(length(p->position - r.at(p->distance)), 1e-5f);
      }
    }
  EXPECT_GT(hits, cam.width * cam.height / 5);
}

TEST(IsosurfaceRaycaster, ShadowRaysSeeTheSphereOnlyWhereItIs) {
  const Volume v = sphere_volume(40);
  const GridTree tree(v);
  const IsosurfaceRaycaster rc(tree, 0.0f);
  const Vec3 up{0, 1, 0};
  const Vec3 under = kCentre + Vec3{0.1f, -0.9f, 0};
  const Vec3 beside = kCentre + Vec3{0.75f, -0.9f, 0};
  EXPECT_LT(rc.first_hit(Ray{under, up}, 0, 10), kInfinity);
  EXPECT_NEAR(rc.first_hit(Ray{under, up}, 0, 10), 0.9f - std::sqrt(kRadius * kRadius - 0.01f), 0.3f * v.spacing().x);
  EXPECT_EQ(rc.first_hit(Ray{beside, up}, 0, 10), kInfinity);
  EXPECT_EQ(rc.first_hit(Ray{under, up}, 0, 0.2f), kInfinity);  // the light is nearer than the sphere
  // A ray that starts inside reports where it leaves.
  EXPECT_NEAR(rc.first_hit(Ray{kCentre, up}, 0, 10), kRadius, 0.3f * v.spacing().x);
}

TEST(IsosurfaceRaycaster, BrickSkippingDropsNothing) {
  const int size = image_size(64);
  for (const auto& [type, iso] : {std::pair{ScalarType::Float32, 0.3f}, std::pair{ScalarType::UInt8, 60.0f}}) {
    SCOPED_TRACE(to_string(type));
    const Volume v = blobs_volume(61, type);
    const GridTree tree(v);
    ASSERT_GE(tree.levels(), 3);
    const Camera cam = reference_camera(size);
    const IsoPoints points = IsosurfaceRaycaster(tree, iso).render(cam);
    const PrimaryRays rays(cam);
    std::size_t next = 0, hits = 0;
    for (int y = 0; y < size; ++y)
      for (int x = 0; x < size; ++x) {
        const auto pixel = static_cast<std::uint32_t>(y * size + x);
        const float t = every_cell_first_hit(v, iso, rays.ray(x, y));
        const bool hit = next < points.size() && points[next].pixel == pixel;
        ASSERT_EQ(hit, t < kInfinity) << x << " " << y;
        if (!hit) continue;
        ++hits;
        EXPECT_NEAR(points[next++].distance, t, 1e-4f * v.spacing().x) << x << " " << y;
      }
    EXPECT_EQ(next, points.size());
    EXPECT_GT(hits, static_cast<std::size_t>(size * size / 10));
  }
}

TEST(IsosurfaceRaycaster, FindsASurfaceLyingOnCellFaces) {
  // Integer data whose isovalue is a plateau: 0 for x < 8, 100 from x = 8 on, isovalue 100. The
  // surface is the voxel plane x = 8, the face between two cells; within the cell before it the
  // crossing falls on the segment's very end, where rounding may put it either side.
  Volume v(ScalarType::UInt8, {16, 16, 16}, {0.5f, 0.5f, 0.5f}, {-4, -4, -4});
  for (int k = 0; k < 16; ++k)
    for (int j = 0; j < 16; ++j)
      for (int i = 8; i < 16; ++i) v.set_value(v.index(i, j, k), 100);
  v.recompute_range();
  const GridTree tree(v);
  const IsosurfaceRaycaster rc(tree, 100.0f);
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1, 1);
  for (int r = 0; r < 2000; ++r) {
    const Ray ray{{-6, u(rng), u(rng)}, normalize(Vec3{1, 0.3f * u(rng), 0.3f * u(rng)})};  // stays in the volume
    ASSERT_NEAR(rc.first_hit(ray, 0, 100), 6 / ray.direction.x, 1e-4f) << r;
  }
}

TEST(MarchingCubes, SphereMeshIsOnTheSurfaceClosedAndHasTheSphereArea) {
  const Volume v = sphere_volume(48);
  const GridTree tree(v);
  const float h = v.spacing().x;
  const TriangleMesh m = marching_cubes(tree, 0.0f);
  ASSERT_GT(m.triangles(), 1000u);
  ASSERT_EQ(m.normals.size(), m.vertices.size());
  for (std::size_t i = 0; i < m.vertices.size(); ++i) {
    const Vec3& p = m.vertices[i];
    ASSERT_LT(std::abs(v.sample(p)), 1e-4f * h) << "off the trilinear surface";
    ASSERT_LT(std::abs(length(p - kCentre) - kRadius), 0.05f * h);
    ASSERT_GT(dot(m.normals[i], normalize(kCentre - p)), 0.99f);  // the gradient points inwards
    ASSERT_LT(length(m.normals[i] - normalize(v.gradient(p))), 1e-4f);
  }
  EXPECT_NEAR(mesh_area(m) / (4 * kPi * kRadius * kRadius), 1.0, 0.02);
  EXPECT_EQ(unmatched_edges(m), 0u);
  EXPECT_GE(m.memory_bytes(), 2 * m.vertices.size() * sizeof(Vec3));
}

TEST(MarchingCubes, ManyCasesGiveAClosedMeshInsideTheCells) {
  // Blobs inside the volume (none touches the border): every case that occurs must close up.
  const Volume v = blobs_volume(45, ScalarType::Float32);
  const GridTree tree(v);
  const TriangleMesh m = marching_cubes(tree, 0.3f);
  ASSERT_GT(m.triangles(), 1000u);
  EXPECT_EQ(unmatched_edges(m), 0u);
  for (const Vec3& p : m.vertices) ASSERT_NEAR(v.sample(p), 0.3f, 1e-5f);
}

TEST(RasterizeMesh, CoversTheRaycastPixelsAtTheSameDepth) {
  const Volume v = sphere_volume(48);
  const GridTree tree(v);
  const float h = v.spacing().x;
  const Camera cam = reference_camera(image_size(128));
  const IsoPoints ref = IsosurfaceRaycaster(tree, 0.0f).render(cam);
  const IsoPoints mesh = rasterize_mesh(marching_cubes(tree, 0.0f), cam);
  std::vector<const IsoPoint*> at(static_cast<std::size_t>(cam.width * cam.height), nullptr);
  for (const IsoPoint& p : mesh) at[p.pixel] = &p;
  std::size_t common = 0;
  for (const IsoPoint& r : ref) {
    const IsoPoint* p = at[r.pixel];
    if (p == nullptr) continue;
    ++common;
    EXPECT_NEAR(p->distance, r.distance, h);
    EXPECT_LE(dot(p->normal, p->position - cam.eye), 0.0f);
    // At a grazing pixel the normal is nearly perpendicular to the ray, turning it to face the eye
    // may go either way.
    if (dot(r.normal, normalize(cam.eye - r.position)) > 0.2f) {
      EXPECT_GT(dot(p->normal, r.normal), 0.98f);
    }
  }
  const std::size_t differ = (ref.size() - common) + (mesh.size() - common);
  EXPECT_LE(differ, ref.size() / 100) << ref.size() << " ray-cast pixels, " << mesh.size() << " rasterised";
  EXPECT_GT(ref.size(), static_cast<std::size_t>(cam.width * cam.height / 5));
}

TEST(RasterizeMesh, SharedEdgesLeaveNoCracks) {
  // A jittered grid of triangles on the plane z = -1 filling the view: every pixel covered once, at
  // the plane's distance. Pixel centres lie exactly on some edges (the grid lines through the centre).
  Camera cam;
  cam.eye = {0, 0, 0};
  cam.target = {0, 0, -1};
  cam.fov_deg = 60;
  cam.width = cam.height = image_size(97);  // odd: a column and a row of centres on x = 0, y = 0
  TriangleMesh m;
  constexpr int kGrid = 24;
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> jitter(-0.3f, 0.3f);
  std::vector<Vec3> p((kGrid + 1) * (kGrid + 1));
  for (int j = 0; j <= kGrid; ++j)
    for (int i = 0; i <= kGrid; ++i) {
      const bool border = i == 0 || j == 0 || i == kGrid || j == kGrid || i == kGrid / 2 || j == kGrid / 2;
      const float step = 2.0f / kGrid;
      p[static_cast<std::size_t>(j * (kGrid + 1) + i)] = {-1 + step * (static_cast<float>(i) + (border ? 0 : jitter(rng))),
                                                          -1 + step * (static_cast<float>(j) + (border ? 0 : jitter(rng))), -1};
    }
  for (int j = 0; j < kGrid; ++j)
    for (int i = 0; i < kGrid; ++i) {
      const auto at = [&](int di, int dj) { return p[static_cast<std::size_t>((j + dj) * (kGrid + 1) + i + di)]; };
      for (const Vec3& q : {at(0, 0), at(1, 0), at(1, 1), at(0, 0), at(1, 1), at(0, 1)}) {
        m.vertices.push_back(q);
        m.normals.push_back({0, 0, 1});
      }
    }
  const IsoPoints points = rasterize_mesh(m, cam);
  ASSERT_EQ(points.size(), static_cast<std::size_t>(cam.width * cam.height));
  const PrimaryRays rays(cam);
  for (const IsoPoint& q : points) {
    const Ray r = rays.ray(static_cast<int>(q.pixel % static_cast<std::uint32_t>(cam.width)), static_cast<int>(q.pixel / static_cast<std::uint32_t>(cam.width)));
    ASSERT_NEAR(q.distance, 1 / -r.direction.z, 1e-4f);
    ASSERT_NEAR(q.position.z, -1, 1e-5f);
    ASSERT_EQ(q.normal, (Vec3{0, 0, 1}));
  }
}

TEST(IsosurfaceReference, SameForOneAndTwoThreads) {
  const Volume v = blobs_volume(45, ScalarType::Float32);
  const GridTree tree(v);
  const Camera cam = reference_camera(image_size(80));
  IsoPoints ray_cast[2], raster[2];
  TriangleMesh mesh[2];
  for (int threads : {1, 2}) {
    ThreadLimit limit(threads);
    const auto i = static_cast<std::size_t>(threads - 1);
    ray_cast[i] = IsosurfaceRaycaster(tree, 0.3f).render(cam);
    mesh[i] = marching_cubes(tree, 0.3f);
    raster[i] = rasterize_mesh(mesh[i], cam);
  }
  EXPECT_FALSE(ray_cast[0].empty());
  EXPECT_TRUE(identical(ray_cast[0], ray_cast[1]));
  EXPECT_EQ(mesh[0].vertices, mesh[1].vertices);
  EXPECT_EQ(mesh[0].normals, mesh[1].normals);
  EXPECT_FALSE(raster[0].empty());
  EXPECT_TRUE(identical(raster[0], raster[1]));
}
