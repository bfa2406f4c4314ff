// What a shadow or ambient technique declares about itself, in its own file: its name, the kinds of
// caster (occluder) it takes, one line of what it is, and every key it reads with type, default,
// allowed range or values, unit and meaning (ParamSpec). The registry (registry/registry.h) lists the
// declarations; from them come the scene file's validation and its "key not read" notes (and
// --strict), the keys the viewer offers, `penumbra techniques` and the key tables of
// docs/scene-file.md. A technique reads its values through its specs: `kOffsets.integer(params)` is
// the scene's value or the declared default.
//
//   const TechniqueInfo& cssm_technique() {
//     static const TechniqueInfo info{"cssm", TechniqueFamily::Shadow, kAllKinds, "coloured stochastic ...",
//                                     {kMapResolution, kMapBias, kLightStep, kOffsets, kSeed},
//                                     {.sphere_rays = true},
//                                     shadow_factory<ColoredStochasticShadowMap>()};
//     return info;
//   }
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "penumbra/lighting/ambient_technique.h"
#include "penumbra/lighting/shadow_technique.h"
#include "penumbra/scene/scene.h"
#include "penumbra/scene/technique_params.h"

namespace penumbra {

enum class TechniqueFamily { Shadow, Ambient };
std::string to_string(TechniqueFamily family);  // "shadows" or "ambient" (the scene file's section)

enum class ParamType { Integer, Number, Choice };

// What the renderer does with a key beyond handing it to the technique: a preview (a frame that
// follows the user's hand) takes a coarser map side, a longer light step and a quarter of the rays;
// accumulated samples move the seed by the sample's number.
enum class ParamRole { Plain, MapSide, LightStep, RayCount, Seed };

struct ParamSpec {
  std::string key;
  ParamType type = ParamType::Number;
  double default_number = 0;  // Integer, Number
  double min = 0, max = 0;    // Integer, Number: the allowed range, both ends included
  std::vector<double> only;   // Integer: when not empty, the only values allowed
  std::vector<double> also;   // Integer, Number: values allowed outside the range (-1: automatic)
  std::string default_choice;          // Choice
  std::vector<std::string> choices;    // Choice
  std::string unit;                    // "texels", "voxels", "degrees", "world units", ...; may be empty
  std::string meaning;                 // one line
  ParamRole role = ParamRole::Plain;

  // The scene's value of the key, or the default.
  std::int64_t integer(const TechniqueParams& params) const;
  double number(const TechniqueParams& params) const;
  const std::string& choice(const TechniqueParams& params) const;
  // Empty when `value` is allowed; else what was expected, for the message that names the key.
  std::string check(const ParamValue& value) const;
  std::string default_text() const;  // the default as the scene file writes it
  std::string allowed_text() const;  // "16 .. 16384", "7, 13 or 21", "per_channel or shared_depth", ...
  std::string type_text() const;     // "integer", "number", "choice"
  bool operator==(const ParamSpec&) const = default;
};

ParamSpec integer_param(std::string key, std::int64_t default_value, std::int64_t min, std::int64_t max, std::string unit,
                        std::string meaning, ParamRole role = ParamRole::Plain);
ParamSpec number_param(std::string key, double default_value, double min, double max, std::string unit, std::string meaning,
                       ParamRole role = ParamRole::Plain);
ParamSpec choice_param(std::string key, std::string default_choice, std::vector<std::string> choices, std::string meaning);

struct TechniqueNeeds {
  bool extinction_sat = false;  // reads the extinction SAT (and `light_cache.resolution`)
  bool sphere_rays = false;     // traces rays through spheres (the renderer builds the Embree BVH)
  bool sphere_order = false;    // splats the spheres (the renderer keeps their spatial order, sphere_order.h)
};

struct TechniqueInfo {
  using ShadowFactory = std::function<std::unique_ptr<ShadowTechnique>(const TechniqueParams&)>;
  using AmbientFactory = std::function<std::unique_ptr<AmbientTechnique>(const TechniqueParams&)>;

  std::string name;
  TechniqueFamily family = TechniqueFamily::Shadow;
  KindMask casters = kAllKinds;  // the kinds of caster (occluder) it takes
  std::string summary;           // one line: what it is, and its paper
  std::vector<ParamSpec> params;
  TechniqueNeeds needs;
  ShadowFactory make_shadow;     // Shadow family ("none": nullptr technique)
  AmbientFactory make_ambient;   // Ambient family

  const ParamSpec* param(std::string_view key) const;
  bool reads(std::string_view key) const { return param(key) != nullptr; }
};

// The factory of a technique constructed from its parameters.
template <class T>
TechniqueInfo::ShadowFactory shadow_factory() {
  return [](const TechniqueParams& p) -> std::unique_ptr<ShadowTechnique> { return std::make_unique<T>(p); };
}
template <class T>
TechniqueInfo::AmbientFactory ambient_factory() {
  return [](const TechniqueParams& p) -> std::unique_ptr<AmbientTechnique> { return std::make_unique<T>(p); };
}

}  // namespace penumbra
