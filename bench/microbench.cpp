// Micro-benchmarks of the hot paths (Google Benchmark): trilinear sampling, the transfer-function
// table, a light-ray march, and one transmittance query of each shadow map; and this machine's
// ceilings for the eye pass (every core): bytes a second read in one pass over a volume, and
// trilinear samples a second along coherent rays, to hold `--stats` throughput against
// (docs/BENCHMARKS.md). The paper-table reproductions are `penumbra bench`.
#include <benchmark/benchmark.h>

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/geometry/sphere_order.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene_io/demo_scenes.h"
#include "penumbra/scene_io/scene_file.h"
#include "penumbra/registry/registry.h"

namespace {
using namespace penumbra;

struct Fixture {
  Scene scene;
  std::unique_ptr<PreparedVolume> prepared;
  std::unique_ptr<ShadowCasters> medium;
  std::vector<Vec3> points;
  Fixture() : scene(build_scene(test_spheres_scene(128), "")) {
    prepared = std::make_unique<PreparedVolume>(*scene.visible_volume());
    // the visible volume casts with its macrocells; the scene's other volumes are not drawn
    std::vector<const MacrocellGrid*> grids(scene.volumes.size(), nullptr);
    grids.at(static_cast<std::size_t>(scene.visible_volume() - scene.volumes.data())) = &prepared->grid;
    medium = std::make_unique<ShadowCasters>(scene, grids);
    for (std::uint64_t i = 0; i < 4096; ++i)
      points.push_back({uniform_float(7, i, 0) - 0.5f, uniform_float(7, i, 1) - 0.5f, uniform_float(7, i, 2) - 0.5f});
  }
};
Fixture& fixture() {
  static Fixture f;
  return f;
}

void BM_TrilinearSample(benchmark::State& state) {
  const Fixture& f = fixture();
  std::size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(f.prepared->volume->sample(f.points[i++ & 4095]));
}
BENCHMARK(BM_TrilinearSample);

void BM_TransferLookup(benchmark::State& state) {
  const Fixture& f = fixture();
  float v = 0;
  for (auto _ : state) {
    benchmark::DoNotOptimize(f.prepared->lut.lookup(v));
    v = v > 1 ? 0 : v + 0.001f;
  }
}
BENCHMARK(BM_TransferLookup);

void BM_ShadowRayMarch(benchmark::State& state) {
  const Fixture& f = fixture();
  std::size_t i = 0;
  for (auto _ : state) {
    const Vec3& p = f.points[i++ & 4095];
    benchmark::DoNotOptimize(f.medium->transmittance(Ray{p, normalize(Vec3{0.3f, 1, 0.2f})}, 0, kInfinity));
  }
}
BENCHMARK(BM_ShadowRayMarch);

void BM_ShadowQuery(benchmark::State& state, const char* technique) {
  const Fixture& f = fixture();
  ShadowSettings s;
  s.technique = technique;
  s.params.set("resolution", 512);
  auto t = make_shadow_technique(s);
  t->build(*f.medium, f.scene.lights[0]);
  std::vector<Rgb> out(32);
  std::size_t i = 0;
  for (auto _ : state) {
    t->transmittance(std::span<const Vec3>(&f.points[(i += 32) & 4064], 32), out);
    benchmark::DoNotOptimize(out.data());
  }
  state.SetItemsProcessed(state.iterations() * 32);
}
BENCHMARK_CAPTURE(BM_ShadowQuery, shadow_map, "shadow_map");
BENCHMARK_CAPTURE(BM_ShadowQuery, deep_shadow_map, "deep_shadow_map");
BENCHMARK_CAPTURE(BM_ShadowQuery, cssm, "cssm");

// The ISSM's generation (paper 003 §3) for a million spheres scattered in id order, as shuffled atoms or
// particles are: a parallel light, a 1024² map. Binning, the nearest-first fill of each tile, the map
// written; what a light drag rebuilds every frame (docs/BENCHMARKS.md, issue 42).
// A million spheres of radius 0.004 uniform in the unit cube, in the order they were drawn (neighbours
// scattered over the set, as in a shuffled or generated file).
const ParticleSet& million_spheres() {
  static const ParticleSet spheres = [] {
    ParticleSet ps;
    for (std::uint64_t i = 0; i < 1000000; ++i)
      ps.spheres.push_back({{uniform_float(11, i, 0) - 0.5f, uniform_float(11, i, 1) - 0.5f, uniform_float(11, i, 2) - 0.5f}, 0.004f});
    return ps;
  }();
  return spheres;
}

// The spheres' spatial order (the renderer builds it once per set; a trajectory, once per frame).
void BM_SphereSpatialOrder(benchmark::State& state) {
  for (auto _ : state) benchmark::DoNotOptimize(spatial_order(million_spheres()).ids.data());
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(million_spheres().size()));
}
BENCHMARK(BM_SphereSpatialOrder)->Unit(benchmark::kMillisecond)->UseRealTime();

void BM_IssmBuild(benchmark::State& state) {
  const ParticleSet& spheres = million_spheres();
  static const SphereOrder order = spatial_order(spheres);
  static const Scene empty;
  ShadowCasters casters(empty, {});
  casters.set_spheres(CastingSpheres{&spheres, nullptr, spheres.bounds(), &order});
  ShadowSettings s;
  s.technique = "issm";
  s.params.set("resolution", 1024);
  auto issm = make_shadow_technique(s);
  Light light;
  light.type = LightType::Directional;
  light.direction = normalize(Vec3{-0.45f, -0.8f, -0.4f});
  for (auto _ : state) issm->build(casters, light);
  state.SetItemsProcessed(state.iterations() * static_cast<std::int64_t>(spheres.size()));
}
BENCHMARK(BM_IssmBuild)->Unit(benchmark::kMillisecond)->UseRealTime();

// Ceiling 1: one pass over 256 MiB of uint16 voxels on every core (a sum, so nothing is skipped).
void BM_CeilingVolumeReadBandwidth(benchmark::State& state) {
  static const std::vector<std::uint16_t> voxels(std::size_t{128} << 20, 7);
  constexpr std::size_t kChunk = std::size_t{1} << 20;
  for (auto _ : state) {
    std::atomic<std::uint64_t> total{0};
    parallel_for(voxels.size() / kChunk, [&](std::size_t c0, std::size_t c1) {
      std::uint64_t sum = 0;
      for (std::size_t i = c0 * kChunk; i < c1 * kChunk; ++i) sum += voxels[i];
      total.fetch_add(sum, std::memory_order_relaxed);
    });
    benchmark::DoNotOptimize(total.load());
  }
  state.SetBytesProcessed(static_cast<std::int64_t>(state.iterations()) * static_cast<std::int64_t>(voxels.size() * sizeof(std::uint16_t)));
}
BENCHMARK(BM_CeilingVolumeReadBandwidth)->UseRealTime()->Unit(benchmark::kMillisecond);

// Ceiling 2: trilinear samples along 64k coherent rays through the 128³ test volume, half a voxel
// apart, on every core: what the eye pass could classify a second with nothing else to do.
void BM_CeilingTrilinearAlongRays(benchmark::State& state) {
  const Fixture& f = fixture();
  const Volume& vol = *f.prepared->volume;
  constexpr int kSide = 256, kSteps = 256;
  for (auto _ : state) {
    std::atomic<double> total{0};
    parallel_for(kSide, [&](std::size_t y0, std::size_t y1) {
      float sum = 0;
      for (std::size_t y = y0; y < y1; ++y)
        for (int x = 0; x < kSide; ++x) {
          const Vec3 origin{(static_cast<float>(x) + 0.5f) / kSide - 0.5f, (static_cast<float>(y) + 0.5f) / kSide - 0.5f, -0.5f};
          for (int k = 0; k < kSteps; ++k) {
            const Vec3 v = vol.to_voxel(origin + Vec3{0, 0, static_cast<float>(k) / kSteps});
            sum += vol.sample_cell_as<float>(vol.trilinear_cell(v));
          }
        }
      double seen = total.load();
      while (!total.compare_exchange_weak(seen, seen + sum)) {}
    });
    benchmark::DoNotOptimize(total.load());
  }
  state.SetItemsProcessed(static_cast<std::int64_t>(state.iterations()) * kSide * kSide * kSteps);
}
BENCHMARK(BM_CeilingTrilinearAlongRays)->UseRealTime()->Unit(benchmark::kMillisecond);

}  // namespace
