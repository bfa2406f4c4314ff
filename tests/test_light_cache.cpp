// The packed light cache (accel/light_cache.h; paper 001 §3: every illumination term with one fetch per
// sample): that a packed fetch returns exactly the floats of the separate fetches it replaces, and that
// the renderer repacks what it must when a light moves or the transfer function changes.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "penumbra/accel/extinction_sat.h"
#include "penumbra/accel/light_cache.h"
#include "penumbra/render/renderer.h"
#include "penumbra/shadows/sat_cone.h"
#include "penumbra/shadows/volume_ambient_occlusion.h"
#include "image_check.h"
#include "test_scenes.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

nlohmann::json two_light_scene() {
  nlohmann::json j = volume_scene({{"name", "test-spheres"}, {"size", 28}}, {{"preset", "test-spheres"}, {"opacity_scale", 3}});
  j["volumes"][0]["compositing"] = "extinction";
  j["shadows"] = {{"technique", "sat_cone"}};
  j["ambient"] = {{"technique", "sat_shells"}};
  j["light_cache"] = {{"resolution", 24}};
  j["camera"] = {{"width", 40}, {"height", 40}};
  j["lights"] = nlohmann::json::array({{{"type", "point"}, {"position", {0.6, 0.9, 0.4}}, {"intensity", 0.6}},
                                       {{"type", "directional"}, {"direction", {-0.5, -0.3, 0.8}}, {"intensity", 0.5}}});
  return j;
}

bool same_float(float a, float b) { return (std::isnan(a) && std::isnan(b)) || a == b; }

}  // namespace

// Proves a packed fetch returns bit for bit what each source's own CellField fetch returns (so images
// do not change), and fails exactly where theirs do (outside the box, next to an unfilled cell), for the
// four-float layout (ambient + one light, the paper's RGBA texture), the eight-float one (ambient + two
// lights) and lights alone, at random points inside and around the grid.
TEST(LightCache, PackedFetchEqualsSeparateFetches) {
  MediumHolder holder(two_light_scene());
  const VolumeObject& v = *holder.scene.visible_volume();
  const ExtinctionSat sat(*v.volume, v.shadow_tf(), v.compositing, v.reference_step(), 24, false);
  holder.medium->attach_extinction_sat(&sat);
  AmbientSettings as;
  as.technique = "sat_shells";
  SatShellsAmbient ao(as.params);
  ao.build(*holder.medium);
  ShadowSettings ss;
  ss.technique = "sat_cone";
  SatConeShadows cone0(ss.params), cone1(ss.params);
  cone0.build(*holder.medium, holder.scene.lights.at(0));
  cone1.build(*holder.medium, holder.scene.lights.at(1));
  std::size_t unfilled_cells = 0;
  for (std::size_t c = 0; c < cone0.cache().size(); ++c) unfilled_cells += std::isnan(cone0.cache()[c]) ? 1 : 0;
  ASSERT_GT(unfilled_cells, 0u);  // the fallback path is exercised

  struct Layout {
    bool ambient;
    std::vector<const SatConeShadows*> lights;
  };
  for (const Layout& layout : {Layout{true, {&cone0}}, Layout{true, {&cone0, &cone1}}, Layout{false, {&cone1, &cone0}}}) {
    LightCache cache(CellLattice(sat), layout.ambient, layout.lights.size());
    if (layout.ambient) cache.set_ambient(ao.cache());
    for (std::size_t s = 0; s < layout.lights.size(); ++s) cache.set_light(s, layout.lights[s]->cache());
    SCOPED_TRACE("channels " + std::to_string(cache.channels()));
    std::mt19937 rng(11);
    std::uniform_real_distribution<float> coord(-0.6f, 0.6f);  // the grid spans [-0.5, 0.5]³
    int fetched = 0, refused = 0;
    for (int n = 0; n < 20000; ++n) {
      const Vec3 p{coord(rng), coord(rng), coord(rng)};
      float packed[LightCache::kMaxChannels];
      const bool ok = cache.try_fetch(p, packed);
      bool want_ok = true;
      if (layout.ambient) {
        Rgb a;
        want_ok = ao.cache().try_fetch(p, a) && want_ok;
        if (ok) {
          ASSERT_TRUE(same_float(packed[0], a.r) && same_float(packed[1], a.g) && same_float(packed[2], a.b));
        }
      }
      for (std::size_t s = 0; s < layout.lights.size(); ++s) {
        float t = 0;
        want_ok = layout.lights[s]->cache().try_fetch(p, t) && want_ok;
        if (ok) {
          ASSERT_TRUE(same_float(packed[cache.light_channel(s)], t)) << "light slot " << s;
        }
      }
      ASSERT_EQ(ok, want_ok) << p.x << " " << p.y << " " << p.z;
      (ok ? fetched : refused) += 1;
    }
    EXPECT_GT(fetched, 1000);
    EXPECT_GT(refused, 1000);
  }
}

// Proves the renderer packs the ambient term and both lights (the cache exists), and repacks exactly
// what changed: after a light moves, after the transfer function changes and after both lights move,
// its frame equals byte for byte a fresh renderer's frame of the same state. Leaving a moved light's
// channel stale would show its old shadow and fail this.
TEST(LightCache, RepackingFollowsLightAndTransferFunctionEdits) {
  const Scene scene = build_scene(two_light_scene(), "");
  Renderer r(scene);
  const FrameResult first = r.render();
  EXPECT_GT(r.light_cache_memory_bytes(), 0u);
  FailureImages keep;
  auto expect_fresh = [&](const FrameResult& got, const Scene& state, const std::vector<Light>& lights, const char* what) {
    const FrameResult want = Renderer(state).render(state.camera, lights);
    keep.add(what, got.image, want.image);
    EXPECT_EQ(compare_images(got.image, want.image).max_abs, 0.0) << what;
  };
  expect_fresh(first, scene, scene.lights, "first");
  std::vector<Light> moved = scene.lights;
  moved[1].direction = normalize(Vec3{0.7f, -0.6f, -0.2f});
  const FrameResult after_move = r.render(scene.camera, moved);
  EXPECT_EQ(after_move.rebuilt, (std::vector<std::string>{"lights.1.shadows"}));
  EXPECT_GT(compare_images(first.image, after_move.image).max_abs, 1e-3);
  expect_fresh(after_move, scene, moved, "light_1_moved");

  const TransferFunction tf(std::vector<TransferPoint>{
      {0.0f, {0, 0, 0}, 0.0f}, {0.3f, {0.9f, 0.4f, 0.2f}, 0.2f}, {1.0f, {1, 1, 1}, 0.9f}});
  r.set_transfer_function(tf);
  const FrameResult after_tf = r.render(scene.camera, moved);
  Scene edited = scene;
  edited.volumes[0].transfer_function = tf;
  expect_fresh(after_tf, edited, moved, "tf_changed");

  moved[0].position = {-0.8f, 0.6f, 0.5f};
  moved[1].direction = normalize(Vec3{-0.2f, -0.9f, 0.3f});
  expect_fresh(r.render(scene.camera, moved), edited, moved, "both_moved");
}

// Proves a frame with a single cached term (one light, no ambient technique) packs nothing: the
// light's own cache is read, and no memory is spent on a copy.
TEST(LightCache, OneTermAloneIsNotPacked) {
  nlohmann::json j = two_light_scene();
  j["ambient"] = {{"technique", "none"}};
  j["lights"].erase(1);
  Renderer r(build_scene(j, ""));
  (void)r.render();
  EXPECT_EQ(r.light_cache_memory_bytes(), 0u);
}
