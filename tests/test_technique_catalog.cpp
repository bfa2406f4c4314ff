// The technique catalogue (registry/technique_catalog.h) is the table the scene reader uses to tell a user
// that a key is not read by the chosen technique. These tests hold it to the truth, through the whole
// renderer: for every technique of every kind of scene and every key of its family, a frame with the
// key changed to a clearly different value differs from the frame without the change exactly when the
// catalogue says the technique reads the key, and the scene's unread_keys name the key exactly when it
// does not. A key that is parsed and ignored, or read but not listed, fails here.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <string>
#include <vector>

#include "penumbra/engine/engine.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene_io/scene_file.h"
#include "penumbra/registry/technique_catalog.h"
#include "test_scenes.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

using nlohmann::json;

// Small scenes of each kind with a floor that receives shadows and a light from above at an angle.
// The floor only receives: every frame's shadows come from the technique under test.
json base_scene(ObjectKind kind) {
  json j;
  j["camera"] = {{"width", 40}, {"height", 40}, {"direction", {1.0, 0.8, 1.2}}};
  j["lights"] = json::array({{{"type", "directional"}, {"direction", {-0.4, -1.0, -0.3}}}});
  j["planes"] = json::array({{{"point", {0.0, -0.6, 0.0}}, {"normal", {0.0, 1.0, 0.0}}, {"casts_shadows", false}}});
  switch (kind) {
    case ObjectKind::Volume:
      // coloured, so that colour keys (bleeding, the deep map's layouts) show
      j["volumes"] = json::array({{{"procedural", {{"name", "test-spheres"}, {"size", 24}}},
                                   {"transfer_function",
                                    {{"points", {{0.0, 1.0, 0.3, 0.2, 0.0}, {0.3, 1.0, 0.3, 0.2, 0.08}, {1.0, 0.2, 0.5, 1.0, 0.6}}}}}}});
      j["light_cache"] = {{"resolution", 16}};
      break;
    case ObjectKind::Spheres:
      j["particles"] = json::array({{{"procedural", {{"name", "random-spheres"}, {"count", 300}, {"radius", 0.05}}}}});
      break;
    case ObjectKind::Isosurface:
      j["volumes"] = json::array({{{"procedural", {{"name", "test-spheres"}, {"size", 24}}}, {"visible", false}}});
      j["isosurfaces"] = json::array({{{"value", 0.5}}});
      break;
    case ObjectKind::Plane:
      break;
  }
  return j;
}

// The kind of scene a technique is tested in: the first kind of caster it takes (volumes for the
// techniques that take every kind; their other kinds are tested in test_mixed_scenes.cpp).
ObjectKind primary_kind(const TechniqueInfo& t) {
  for (ObjectKind k : {ObjectKind::Volume, ObjectKind::Spheres, ObjectKind::Isosurface})
    if (t.casters & kind_bit(k)) return k;
  return ObjectKind::Volume;
}

struct KeyChange {
  json value;    // a value far from the default, so that a technique that reads the key changes the frame
  json enable;   // other keys of the section that make this one matter (e.g. area_rays needs light_angle > 0)
  // a key whose effect shows from the second build on (particle_ao's reuse keeps what the first built):
  // tested, where the technique lists it and takes spheres, in the spheres' scene on the frame after they grew
  bool across_builds = false;
};

// Every key of `shadows` and `ambient` with its changed value. The base values keep the frames cheap
// (map resolutions of 64, 8 sampled-cone rays, a light cache of 16 cells).
const std::map<std::string, KeyChange>& shadow_keys() {
  static const std::map<std::string, KeyChange> keys{
      {"resolution", {32, json::object()}},  // from 64
      {"bias", {0.3, json::object()}},
      {"step", {3.0, json::object()}},
      {"pcf", {2, json::object()}},
      {"nodes", {2, json::object()}},
      {"dsm_layout", {"shared_depth", json::object()}},
      {"offsets", {7, json::object()}},
      {"seed", {2, json::object()}},
      {"cone_angle", {20.0, json::object()}},
      {"cone_samples", {4.0, json::object()}},
      {"cone_growth", {0.8, json::object()}},
      {"cone_rays", {2, json::object()}},  // from 8
      {"rings", {0, {{"resolution", 256}}}},
      // b = 0.3: the default 10 makes the penumbra of occluders a few tenths away vanishingly thin
      {"soft_radius", {0.08, {{"soft_distance", 0.3}}}},
      {"soft_exponent", {4.0, {{"soft_radius", 0.08}, {"soft_distance", 0.3}}}},
      {"soft_distance", {0.05, {{"soft_radius", 0.08}}}},
      {"light_angle", {6.0, json::object()}},
      {"area_rays", {2, {{"light_angle", 6.0}}}},
      {"light_frustum", {"volume", json::object()}},
  };
  return keys;
}

const std::map<std::string, KeyChange>& ambient_keys() {
  static const std::map<std::string, KeyChange> keys{
      {"shells", {1, json::object()}},
      {"radius", {0.5, json::object()}},  // 8 cells of the 16-cell cache: shells of other half-sizes
      {"bleeding", {1.0, json::object()}},
      {"directions", {4, json::object()}},
      {"max_distance", {0.1, json::object()}},
      {"grid", {8, json::object()}},
      {"rays", {4, json::object()}},
      {"reuse", {1.0, json::object(), true}},
  };
  return keys;
}

Image render(const json& j) { return Renderer(build_scene(j, "")).render().image; }

// The frame after the spheres of base_scene(Spheres) grew by 4 % (a tenth of a density cell), on the
// renderer that drew them before.
Image render_after_growing(const json& j) {
  Engine engine(j, "");
  (void)engine.render();
  engine.set("particles.0.procedural.radius", 0.052);
  return engine.render().image;
}

bool notes_name(const Scene& s, const std::string& path) {
  return std::any_of(s.unread_keys.begin(), s.unread_keys.end(),
                     [&](const std::string& n) { return n.rfind(path + " ", 0) == 0; });
}

void check_family(TechniqueFamily family) {
  const std::string section = family == TechniqueFamily::Shadow ? "shadows" : "ambient";
  const auto& keys = family == TechniqueFamily::Shadow ? shadow_keys() : ambient_keys();
  // Every key a technique declares is one this test changes (a new key needs a row above).
  for (const TechniqueInfo* t : technique_catalog()) {
    if (t->family != family) continue;
    for (const ParamSpec& p : t->params) {
      EXPECT_TRUE(keys.count(p.key)) << t->name << " reads " << p.key << ", which this test does not change";
    }
  }
  for (const TechniqueInfo* info : technique_catalog()) {
    const TechniqueInfo& t = *info;
    if (t.family != family) continue;
    SCOPED_TRACE(std::string(t.name) + " in a scene of " + to_string(primary_kind(t)));
    for (const auto& [key, change] : keys) {
      SCOPED_TRACE(section + "." + key);
      const bool across_builds = change.across_builds && t.reads(key) && (t.casters & kind_bit(ObjectKind::Spheres));
      json base = base_scene(across_builds ? ObjectKind::Spheres : primary_kind(t));
      base[section] = {{"technique", std::string(t.name)}};
      if (family == TechniqueFamily::Shadow) {
        base[section]["resolution"] = 64;
        base[section]["cone_rays"] = 8;  // sampled_cone traces this many exact rays per volume sample
      }
      for (const auto& [k, v] : change.enable.items()) base[section][k] = v;
      json changed = base;
      changed[section][key] = change.value;
      const Scene scene = build_scene(changed, "");
      const bool read = t.reads(key);
      EXPECT_EQ(notes_name(scene, section + "." + key), !read);
      const Image a = across_builds ? render_after_growing(base) : render(base);
      const Image b = across_builds ? render_after_growing(changed) : render(changed);
      EXPECT_EQ(a.pixels() != b.pixels(), read) << (read ? "listed as read, but the frame did not change"
                                                         : "not listed, but the frame changed");
    }
  }
}

}  // namespace

TEST(TechniqueCatalog, ShadowKeysAreReadExactlyWhereListed) { check_family(TechniqueFamily::Shadow); }

TEST(TechniqueCatalog, AmbientKeysAreReadExactlyWhereListed) { check_family(TechniqueFamily::Ambient); }

// The light cache is read only by the extinction techniques.
TEST(TechniqueCatalog, LightCacheIsReadOnlyByExtinctionTechniques) {
  for (const char* technique : {"none", "shadow_map", "sat_cone"}) {
    SCOPED_TRACE(technique);
    json base = base_scene(ObjectKind::Volume);
    base["shadows"] = {{"technique", technique}, {"resolution", 64}};
    json changed = base;
    changed["light_cache"]["resolution"] = 8;
    const bool read = find_technique(TechniqueFamily::Shadow, technique)->needs.extinction_sat;
    EXPECT_EQ(notes_name(build_scene(changed, ""), "light_cache"), !read);
    EXPECT_EQ(render(base).pixels() != render(changed).pixels(), read);
  }
}

// Every name the reader accepts is in the catalogue once, "none" first, for every kind of caster.
TEST(TechniqueCatalog, NamesAreUniquePerKindAndNoneComesFirst) {
  for (auto family : {TechniqueFamily::Shadow, TechniqueFamily::Ambient})
    for (auto kind : {ObjectKind::Volume, ObjectKind::Spheres, ObjectKind::Isosurface, ObjectKind::Plane}) {
      const auto names = technique_names(family, kind);
      ASSERT_FALSE(names.empty());
      EXPECT_EQ(names.front(), "none");
      for (std::size_t i = 0; i < names.size(); ++i)
        EXPECT_EQ(std::count(names.begin(), names.end(), names[i]), 1) << names[i];
    }
}
