// A technique declares its keys in its own file (lighting/technique_info.h), and adding one is one file
// pair and one registry line. This file is such a technique's file pair — `dimmer`, which passes a
// declared share of the light to every receiver — registered at run time as the registry's line would
// (register_technique). Without any other file touched it is read from a scene (its key validated and
// its unread notes given), listed, documented by `penumbra techniques`, and rendered. The built-in
// declarations are checked too: a key means one thing to every technique that reads it, and the
// committed docs/scene-file.md holds exactly the tables the declarations generate.
#include <gtest/gtest.h>

#include <algorithm>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>

#include "error_message.h"
#include "image_check.h"
#include "penumbra/core/error.h"
#include "penumbra/registry/registry.h"
#include "penumbra/registry/technique_catalog.h"
#include "penumbra/registry/technique_docs.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene_io/scene_file.h"
#include "test_scenes.h"

using namespace penumbra;
using namespace penumbra::test;
using nlohmann::json;

namespace {

// ---- the technique's file pair: its declaration and its class ----

const ParamSpec kDimming = number_param("dimming", 0.5, 0, 1, "of the light", "the share of the light every receiver gets");

class Dimmer final : public ShadowTechnique {
public:
  using ShadowTechnique::transmittance;
  explicit Dimmer(const TechniqueParams& params) : share_(static_cast<float>(kDimming.number(params))) {}
  void build(const ShadowCasters&, const Light&) override {}
  void transmittance(std::span<const Vec3>, std::span<Rgb> out) const override { std::fill(out.begin(), out.end(), Rgb(share_)); }
  Vec3 surface_receiver(const Vec3& p, const Vec3&) const override { return p; }
  std::size_t memory_bytes() const override { return 0; }
  std::string_view name() const override { return "dimmer"; }

private:
  float share_;
};

const TechniqueInfo& dimmer_technique() {
  static const TechniqueInfo info{"dimmer", TechniqueFamily::Shadow, kAllKinds, "a test technique: every receiver gets a share of the light",
                                  {kDimming}, {}, shadow_factory<Dimmer>(), {}};
  return info;
}

// ---- the registry's line (run time, for the test) ----

struct Registered {
  Registered() { register_technique(dimmer_technique()); }
  ~Registered() { unregister_technique(TechniqueFamily::Shadow, "dimmer"); }
};

json dimmer_scene(double dimming) {
  json j = volume_scene({{"name", "sphere"}, {"size", 12}}, step_tf(0.5, 0.9, 0.6, 0.4));
  j["planes"] = json::array({{{"point", {0, -0.6, 0}}, {"normal", {0, 1, 0}}, {"size", 3}}});
  j["shadows"] = {{"technique", "dimmer"}, {"dimming", dimming}};
  return j;
}

#define EXPECT_ERROR_HAS(call, part)                                          \
  do {                                                                        \
    const std::string m_ = error_message([&] { (void)(call); });              \
    EXPECT_NE(m_.find(part), std::string::npos) << "error: '" << m_ << "'"; \
  } while (0)

double mean_luminance(const Image& img) {
  double s = 0;
  for (const Rgb& p : img.pixels()) s += (p.r + p.g + p.b) / 3.0;
  return s / static_cast<double>(img.pixels().size());
}

}  // namespace

TEST(TechniqueDeclaration, ATechniqueInItsOwnFileIsReadValidatedListedDocumentedAndRendered) {
  auto registered = std::make_unique<Registered>();
  // listed
  const auto names = technique_names(TechniqueFamily::Shadow);
  EXPECT_NE(std::find(names.begin(), names.end(), "dimmer"), names.end());
  ASSERT_NE(find_param(TechniqueFamily::Shadow, "dimming"), nullptr);
  // read, and validated against its declaration
  const Scene scene = build_scene(dimmer_scene(0.25), "");
  EXPECT_EQ(kDimming.number(scene.shadows.params), 0.25);
  EXPECT_ERROR_HAS(build_scene(dimmer_scene(1.5), ""), "shadows.dimming");
  EXPECT_ERROR_HAS(build_scene(dimmer_scene(1.5), ""), "0 .. 1");
  json text = dimmer_scene(0.25);
  text["shadows"]["dimming"] = "dark";
  EXPECT_ERROR_HAS(build_scene(text, ""), "shadows.dimming");
  // its key is noted as unread under another technique, and another technique's key under it
  json other = dimmer_scene(0.25);
  other["shadows"]["technique"] = "ray_traced";
  const Scene under_other = build_scene(other, "");
  ASSERT_EQ(under_other.unread_keys.size(), 1u);
  EXPECT_NE(under_other.unread_keys[0].find("shadows.dimming is not read by ray_traced"), std::string::npos) << under_other.unread_keys[0];
  json foreign = dimmer_scene(0.25);
  foreign["shadows"]["pcf"] = 2;
  EXPECT_EQ(build_scene(foreign, "").unread_keys.size(), 1u);
  // documented
  const std::string md = technique_keys_markdown();
  EXPECT_NE(md.find("#### `shadows.technique`: `dimmer`"), std::string::npos);
  EXPECT_NE(md.find("| `shadows.dimming` | number | 0.5 | 0 .. 1 | of the light | the share of the light every receiver gets |"), std::string::npos) << md;
  // rendered: the light the receivers get is the declared share (its default too)
  const double quarter = mean_luminance(Renderer(build_scene(dimmer_scene(0.25), "")).render().image);
  const double full = mean_luminance(Renderer(build_scene(dimmer_scene(1.0), "")).render().image);
  json by_default = dimmer_scene(0.5);
  by_default["shadows"].erase("dimming");
  const double half = mean_luminance(Renderer(build_scene(by_default, "")).render().image);
  EXPECT_LT(quarter, half);
  EXPECT_LT(half, full);
  // and gone once unregistered: a scene naming it is refused
  registered.reset();
  EXPECT_ERROR_HAS(build_scene(dimmer_scene(0.25), ""), "unknown technique 'dimmer'");
}

// A technique that declares a shared key unlike the others is refused, and so is a second of one name.
TEST(TechniqueDeclaration, RegistrationRefusesADifferentMeaningForAKeyAndATakenName) {
  static const TechniqueInfo other_resolution{"wide", TechniqueFamily::Shadow, kAllKinds, "declares resolution differently",
                                              {integer_param("resolution", 64, 1, 8, "texels", "something else")}, {}, shadow_factory<Dimmer>(), {}};
  EXPECT_ERROR_HAS(register_technique(other_resolution), "shadows.resolution");
  static const TechniqueInfo taken{"cssm", TechniqueFamily::Shadow, kAllKinds, "a second cssm", {}, {}, shadow_factory<Dimmer>(), {}};
  EXPECT_ERROR_HAS(register_technique(taken), "registered already");
  EXPECT_FALSE(unregister_technique(TechniqueFamily::Shadow, "cssm")) << "a built-in technique stays";
}

// Every key the built-in techniques share is declared alike by each, and every declared default is
// allowed by its own declaration.
TEST(TechniqueDeclaration, SharedKeysAreDeclaredAlikeAndDefaultsAreAllowed) {
  for (const TechniqueInfo* t : technique_catalog())
    for (const ParamSpec& p : t->params) {
      SCOPED_TRACE(t->name + "." + p.key);
      EXPECT_EQ(*find_param(t->family, p.key), p);
      const ParamValue def = p.type == ParamType::Choice    ? ParamValue(p.default_choice)
                             : p.type == ParamType::Integer ? ParamValue(static_cast<std::int64_t>(p.default_number))
                                                            : ParamValue(p.default_number);
      EXPECT_EQ(p.check(def), "");
      EXPECT_FALSE(p.meaning.empty());
    }
}

// docs/scene-file.md holds the tables the declarations generate; when a technique or key changes,
// `penumbra techniques --update-doc docs/scene-file.md` writes them anew.
TEST(TechniqueDeclaration, TheSceneFilePageHoldsTheGeneratedKeyTables) {
  std::ifstream in(std::string(PENUMBRA_SOURCE_DIR) + "/docs/scene-file.md");
  ASSERT_TRUE(in) << "docs/scene-file.md not found";
  std::ostringstream page;
  page << in.rdbuf();
  EXPECT_EQ(generated_section(page.str(), "docs/scene-file.md"), technique_keys_markdown() + "\n")
      << "docs/scene-file.md's technique keys differ from the declarations: run `build/release/penumbra techniques --update-doc docs/scene-file.md`";
}

// As the scene file always read them: null is the default, and an integral number (512.0, as JSON
// writers and Python floats give it) is an integer; 64.5 is not.
TEST(TechniqueDeclaration, NullIsTheDefaultAndAnIntegralNumberIsAnInteger) {
  json j = volume_scene({{"name", "sphere"}, {"size", 8}}, step_tf(0.5));
  j["shadows"] = {{"technique", "cssm"}, {"resolution", 64.0}, {"step", nullptr}};
  const Scene s = build_scene(j, "");
  EXPECT_EQ(param_integer(TechniqueFamily::Shadow, s.shadows.params, "resolution"), 64);
  EXPECT_EQ(s.shadows.params.find("step"), nullptr);
  j["shadows"]["resolution"] = 64.5;
  EXPECT_ERROR_HAS(build_scene(j, ""), "shadows.resolution: expected an integer (16 .. 16384), got 64.5");
  j["shadows"]["resolution"] = 64;
  j["shadows"]["seed"] = 18446744073709551615ull;
  EXPECT_ERROR_HAS(build_scene(j, ""), "shadows.seed");
}
