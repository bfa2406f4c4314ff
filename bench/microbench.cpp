// Micro-benchmarks of the hot paths (Google Benchmark): trilinear sampling, the transfer-function
// table, a light-ray march, and one transmittance query of each shadow map. The paper-table
// reproductions are `penumbra bench`.
#include <benchmark/benchmark.h>

#include <memory>

#include "penumbra/core/rng.h"
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

}  // namespace
