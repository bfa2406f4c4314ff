// The scene file and `--set` overrides (docs/scene-file.md): dotted paths into objects and arrays, JSON
// versus string values, and every kind of bad input giving an Error that names the dotted key path.
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "error_message.h"
#include "penumbra/core/error.h"
#include "penumbra/scene_io/scene_file.h"
#include "penumbra/registry/technique_catalog.h"
#include "test_scenes.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

// A valid, small scene with every section that has keys of its own.
nlohmann::json base_scene() {
  return nlohmann::json::parse(R"({
    "volumes": [ { "procedural": { "name": "sphere", "size": 16 }, "transfer_function": { "preset": "grayscale" } } ],
    "planes": [ { "point": [0, -0.6, 0], "normal": [0, 1, 0] } ],
    "lights": [ { "type": "point", "position": [1, 2, 1], "intensity": 1 }, { "type": "directional" } ],
    "camera": { "width": 16, "height": 16 },
    "shadows": { "technique": "none", "resolution": 64 }
  })");
}

// build_scene must throw an Error whose message contains every one of `needles`.
void expect_error(const nlohmann::json& j, std::initializer_list<std::string> needles) {
  try {
    (void)build_scene(j, "");
    ADD_FAILURE() << "no error for " << j.dump();
  } catch (const Error& e) {
    const std::string what = e.what();
    for (const auto& n : needles) EXPECT_NE(what.find(n), std::string::npos) << "'" << n << "' missing in: " << what;
  }
}

nlohmann::json with(nlohmann::json j, const std::string& path, const std::string& value) {
  apply_override(j, path, value);
  return j;
}

}  // namespace

TEST(SceneFile, BaseSceneBuilds) {
  const Scene s = build_scene(base_scene(), "");
  EXPECT_EQ(s.volumes.size(), 1u);
  EXPECT_EQ(s.planes.size(), 1u);
  ASSERT_EQ(s.lights.size(), 2u);
  EXPECT_EQ(s.lights[0].type, LightType::Point);
  EXPECT_EQ(s.camera.width, 16);
  EXPECT_EQ(static_cast<int>(param_integer(TechniqueFamily::Shadow, s.shadows.params, "resolution")), 64);
}

TEST(SceneFile, OverridesReachNestedObjectsAndArrayElements) {
  nlohmann::json j = base_scene();
  apply_override(j, "lights.0.intensity=2.5");
  apply_override(j, "lights.1.color", "[0.5, 0.25, 1]");
  apply_override(j, "volumes.0.procedural.radius=0.2");
  apply_override(j, "shadows.seed=7");
  apply_override(j, "camera.eye=[1,2,3]");
  apply_override(j, "ambient.technique=none");  // a missing object on the path is created
  EXPECT_EQ(j["lights"][0]["intensity"], 2.5);
  EXPECT_EQ(j["lights"][1]["color"], nlohmann::json({0.5, 0.25, 1}));
  EXPECT_EQ(j["volumes"][0]["procedural"]["radius"], 0.2);
  EXPECT_EQ(j["ambient"]["technique"], "none");
  const Scene s = build_scene(j, "");
  EXPECT_FLOAT_EQ(s.lights[0].intensity, 2.5f);
  EXPECT_FLOAT_EQ(s.lights[1].color.b, 1.0f);
  EXPECT_EQ(static_cast<int>(param_integer(TechniqueFamily::Shadow, s.shadows.params, "seed")), 7u);
  EXPECT_FLOAT_EQ(s.camera.eye.z, 3.0f);
  // The value is everything after the first '='.
  nlohmann::json k;
  apply_override(k, "a.b=c=d");
  EXPECT_EQ(k["a"]["b"], "c=d");
}

TEST(SceneFile, ValuesAreJsonWhenValidElseStrings) {
  nlohmann::json j = base_scene();
  apply_override(j, "shadows.resolution=2048");
  ASSERT_TRUE(j["shadows"]["resolution"].is_number_integer());
  EXPECT_EQ(j["shadows"]["resolution"].get<int>(), 2048);
  apply_override(j, "shadows.technique=cssm");
  ASSERT_TRUE(j["shadows"]["technique"].is_string());
  EXPECT_EQ(j["shadows"]["technique"], "cssm");
  apply_override(j, "planes=[]");
  ASSERT_TRUE(j["planes"].is_array());
  EXPECT_TRUE(j["planes"].empty());
  apply_override(j, "shadows.bias=0.01");
  EXPECT_TRUE(j["shadows"]["bias"].is_number_float());
  apply_override(j, "volumes.0.jitter=false");
  EXPECT_TRUE(j["volumes"][0]["jitter"].is_boolean());
  apply_override(j, "lights.0.type=\"spot\"");  // quoted: JSON string
  EXPECT_EQ(j["lights"][0]["type"], "spot");
  const Scene s = build_scene(j, "");
  EXPECT_EQ(static_cast<int>(param_integer(TechniqueFamily::Shadow, s.shadows.params, "resolution")), 2048);
  EXPECT_EQ(s.shadows.technique, "cssm");
  EXPECT_TRUE(s.planes.empty());
  EXPECT_FALSE(s.volumes[0].jitter);
  EXPECT_EQ(s.lights[0].type, LightType::Spot);
}

// A scene without "lights" has one default light; its keys are edited by path like any light's.
TEST(SceneFile, TheDefaultLightIsEditedByPath) {
  nlohmann::json j = base_scene();
  j.erase("lights");
  const Scene before = build_scene(j, "");
  apply_override(j, "lights.0.direction=[0, -1, 0]");
  ASSERT_EQ(j["lights"].size(), 1u);
  const Scene after = build_scene(j, "");
  ASSERT_EQ(after.lights.size(), 1u);
  EXPECT_FLOAT_EQ(after.lights[0].direction.y, -1.0f);
  EXPECT_EQ(after.lights[0].type, before.lights[0].type);
  EXPECT_FLOAT_EQ(after.lights[0].intensity, before.lights[0].intensity);
  nlohmann::json k = base_scene();
  k.erase("lights");
  EXPECT_NE(error_message([&] { apply_override(k, "lights.1.intensity=2"); }).find("past the end"), std::string::npos);
}

TEST(SceneFile, BadOverridePathsAreErrors) {
  nlohmann::json j = base_scene();
  EXPECT_THROW(apply_override(j, "lights.2.intensity=1"), Error);  // past the end (2 lights)
  EXPECT_THROW(apply_override(j, "lights.x.intensity=1"), Error);  // not an index
  EXPECT_THROW(apply_override(j, "lights.-1.intensity=1"), Error);
  EXPECT_THROW(apply_override(j, "shadows.technique.name=x"), Error);  // inside a string
  EXPECT_THROW(apply_override(j, "shadows..seed=1"), Error);
  EXPECT_THROW(apply_override(j, "=1"), Error);
  EXPECT_THROW(apply_override(j, "no-equals-sign"), Error);
  try {
    apply_override(j, "lights.5.intensity=1");
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("lights.5"), std::string::npos) << e.what();
  }
  EXPECT_EQ(j, base_scene()) << "failed overrides must not change the scene";
}

TEST(SceneFile, UnknownKeysAnywhereNameTheirPath) {
  for (const std::string path : {"bogus", "shadows.bogus", "camera.bogus", "lights.0.bogus", "lights.1.bogus",
                                 "volumes.0.bogus", "planes.0.bogus", "shading.bogus", "ambient.bogus"}) {
    SCOPED_TRACE(path);
    expect_error(with(base_scene(), path, "1"), {path, "unknown key"});
  }
  // A misspelling through --set is caught the same way.
  expect_error(with(base_scene(), "shadows.resolutoin", "2048"), {"shadows.resolutoin"});
}

TEST(SceneFile, WrongTypesAndRangesNameTheKey) {
  struct Case { std::string path, value; };
  for (const Case& c : std::vector<Case>{{"shadows.resolution", "0"},
                                         {"shadows.resolution", "\"big\""},
                                         {"shadows.resolution", "64.5"},
                                         {"shadows.offsets", "5"},
                                         {"shadows.nodes", "1"},
                                         {"shadows.seed", "-3"},
                                         {"shadows.step", "0.01"},
                                         {"shadows.step", "-0.5"},  // -1 is the default's sentinel, nothing else below 0
                                         {"shadows.bias", "-0.2"},
                                         {"camera.fov_deg", "0"},
                                         {"camera.fov_deg", "\"wide\""},
                                         {"camera.width", "0"},
                                         {"camera.eye", "[1,2]"},
                                         {"lights.0.intensity", "-1"},
                                         {"lights.0.color", "[2,0,0]"},
                                         {"lights.0.type", "laser"},
                                         {"lights.0.position", "null"},
                                         {"planes.0.normal", "[0,0,0]"},
                                         {"volumes.0.step", "0"},
                                         {"volumes.0.compositing", "\"additive\""},
                                         {"volumes.0.visible", "\"yes\""},
                                         {"background", "[0.1,0.2]"},
                                         {"planes", "{}"}}) {
    SCOPED_TRACE(c.path + "=" + c.value);
    expect_error(with(base_scene(), c.path, c.value), {c.path});
  }
}

TEST(SceneFile, TechniqueNames) {
  for (const auto& t : technique_names(TechniqueFamily::Shadow, ObjectKind::Volume)) EXPECT_NO_THROW(build_scene(with(base_scene(), "shadows.technique", t), "")) << t;
  // Unknown: the message lists the valid ones.
  std::vector<std::string> needles{"shadows.technique", "shadow_mapp"};
  for (const auto& t : technique_names(TechniqueFamily::Shadow, ObjectKind::Volume)) needles.push_back(t);
  try {
    (void)build_scene(with(base_scene(), "shadows.technique", "shadow_mapp"), "");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    for (const auto& n : needles) EXPECT_NE(std::string(e.what()).find(n), std::string::npos) << n << " in " << e.what();
  }
  // A technique that takes none of the scene's kinds of caster (here a volume and a plane).
  expect_error(with(base_scene(), "shadows.technique", "light_pass"), {"shadows", "light_pass", "is for isosurfaces", "casters are volumes, planes"});
  expect_error(with(base_scene(), "shadows.technique", "issm"), {"shadows", "issm", "is for spheres"});
  nlohmann::json floor_only = base_scene();  // no occluder an ambient technique takes
  floor_only.erase("volumes");
  expect_error(with(floor_only, "ambient.technique", "particle_ao"), {"ambient", "particle_ao", "is for volumes, spheres", "has none"});
  // A kind given a technique that does not take it.
  expect_error(with(base_scene(), "shadows.volumes", "\"issm\""), {"shadows.volumes", "issm", "does not take volumes"});
  nlohmann::json spheres = base_scene();
  spheres["particles"] = nlohmann::json::parse(R"([{"procedural": {"name": "random-spheres", "count": 10}}])");
  EXPECT_NO_THROW(build_scene(with(spheres, "shadows.technique", "issm"), ""));
  EXPECT_NO_THROW(build_scene(with(spheres, "ambient.technique", "ray_traced_ao"), ""));
  // One scene holds every kind: the maps take the spheres too, and the volume's ambient technique sees
  // the volume.
  EXPECT_NO_THROW(build_scene(with(spheres, "shadows.technique", "cssm"), ""));
  EXPECT_NO_THROW(build_scene(with(spheres, "ambient.technique", "sat_shells"), ""));
  expect_error(with(base_scene(), "ambient.technique", "magic"), {"ambient.technique", "magic"});
}

TEST(SceneFile, VolumeSourceAndTransferFunctionErrors) {
  nlohmann::json j = base_scene();  // (without a transfer function one is chosen: test_open_data.cpp)
  j["volumes"][0]["file"] = "/nonexistent/volume.nrrd";
  expect_error(j, {"volumes.0", "file", "procedural"});  // both given

  j = base_scene();
  j["volumes"][0].erase("procedural");
  expect_error(j, {"volumes.0", "file", "procedural"});  // neither given

  j = base_scene();
  j["volumes"][0].erase("procedural");
  j["volumes"][0]["file"] = "/nonexistent/volume.nrrd";
  expect_error(j, {"volumes.0.file", "/nonexistent/volume.nrrd"});

  expect_error(with(base_scene(), "volumes.0.procedural.name", "cube"), {"volumes.0.procedural", "cube"});
  expect_error(with(base_scene(), "volumes.0.transfer_function", "{\"preset\": \"nope\"}"),
               {"volumes.0.transfer_function", "nope"});
  // Two visible volumes are composited together; the extinction techniques read one volume's SAT
  j = base_scene();
  j["volumes"].push_back(j["volumes"][0]);
  EXPECT_NO_THROW(build_scene(j, ""));
  expect_error(with(j, "shadows.technique", "sat_cone"), {"volumes", "sat_cone", "2 visible volumes"});
  j["volumes"][1]["visible"] = false;
  EXPECT_NO_THROW(build_scene(j, ""));
  // objects that have no shadow flags
  expect_error(with(j, "lights.0.casts_shadows", "false"), {"lights.0.casts_shadows"});
  expect_error(with(j, "camera.receives_shadows", "false"), {"camera.receives_shadows"});
  // an invisible volume has no shadow flags
  expect_error(with(j, "volumes.1.casts_shadows", "true"), {"volumes.1.casts_shadows", "not visible"});
}

TEST(SceneFile, InvalidJsonFileNamesTheFileAndLine) {
  ScratchDir dir;
  const std::string path = dir.file("broken.json");
  // line 3 has a trailing comma before '}'
  std::ofstream(path) << "{\n  \"camera\": { \"width\": 16 },\n  \"shadows\": { \"technique\": \"cssm\", }\n}\n";
  try {
    (void)load_scene(path);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find(path), std::string::npos) << what;
    EXPECT_NE(what.find("line 3"), std::string::npos) << what;
  }
  // Missing file: named as well.
  try {
    (void)load_scene(dir.file("missing.json"));
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("missing.json"), std::string::npos) << e.what();
  }
  // A valid file with a bad key: the file and the key.
  const std::string bad = dir.file("bad.json");
  std::ofstream(bad) << R"({ "shadows": { "technique": "none", "resolutoin": 5 } })";
  try {
    (void)load_scene(bad);
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("bad.json"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("shadows.resolutoin"), std::string::npos) << e.what();
  }
  // Overrides are applied by load_scene too.
  const std::string good = dir.file("good.json");
  std::ofstream(good) << base_scene().dump();
  const Scene s = load_scene(good, {"shadows.technique=cssm", "shadows.resolution=128"});
  EXPECT_EQ(s.shadows.technique, "cssm");
  EXPECT_EQ(static_cast<int>(param_integer(TechniqueFamily::Shadow, s.shadows.params, "resolution")), 128);
}

// particles[].radius: one radius for every sphere of a file (beads and coarse-grained models have no
// element radii); not together with radius_scale, and not for generated spheres.
TEST(SceneFile, ParticleRadiusSetsEverySphere) {
  ScratchDir dir;
  const std::string xyz = dir.file("beads.xyz");
  std::ofstream(xyz) << "3\nbeads\nC 0 0 0\nO 2 0 0\nX 0 3 0\n";
  nlohmann::json j;
  j["particles"] = nlohmann::json::array({{{"file", xyz}}});
  const Scene element = build_scene(j, "");
  ASSERT_EQ(element.particles.at(0).set->size(), 3u);
  EXPECT_NE(element.particles[0].set->spheres[0].radius, element.particles[0].set->spheres[1].radius) << "C and O differ";
  j["particles"][0]["radius"] = 0.75;
  const Scene beads = build_scene(j, "");
  for (const Sphere& s : beads.particles.at(0).set->spheres) EXPECT_EQ(s.radius, 0.75f);
  j["particles"][0]["radius_scale"] = 2;
  expect_error(j, {"particles.0.radius", "radius_scale", "not both"});
  nlohmann::json generated;
  generated["particles"] = nlohmann::json::parse(R"([{"procedural": {"name": "random-spheres", "count": 10}, "radius": 0.1}])");
  expect_error(generated, {"particles.0.radius", "procedural"});
  j["particles"][0].erase("radius_scale");
  j["particles"][0]["radius"] = -1;
  expect_error(j, {"particles.0.radius"});
}

// A scene built in code gets the reader's checks across objects from validate_scene, each naming the key.
TEST(SceneFile, ValidateSceneChecksASceneBuiltInCode) {
  Scene s = build_scene(volume_scene({{"name", "sphere"}, {"size", 16}}, step_tf(0.5)), "");
  EXPECT_NO_THROW(validate_scene(s));
  auto refused = [](Scene bad, const std::string& key) {
    try {
      validate_scene(bad);
      ADD_FAILURE() << key << " accepted";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()).rfind(key + ":", 0), 0u) << e.what();
    }
  };
  Scene iso = s;
  IsosurfaceObject o;
  o.value = 1e6f;
  iso.isosurfaces.push_back(o);
  refused(iso, "isosurfaces.0.value");
  iso.isosurfaces[0].volume = 3;
  refused(iso, "isosurfaces.0.volume");
  Scene technique = s;
  technique.shadows.technique = "issm";  // takes spheres; the scene has a volume
  refused(technique, "shadows");
  technique.shadows.technique = "magic";
  refused(technique, "shadows.technique");
  Scene sat = s;
  sat.shadows.technique = "sat_cone";
  sat.volumes.push_back(sat.volumes[0]);
  refused(sat, "volumes");
  Scene light = s;
  light.lights[0].direction = {0, 0, 0};
  refused(light, "lights.0.direction");
}
