// What the scene file and the renderer ask of the techniques, answered from the declarations the
// registry lists (registry.h; each technique declares itself in its own file, lighting/technique_info.h):
// names, the kinds of caster each takes, the keys each reads, whether it needs the extinction SAT or
// rays through spheres. The scene reader validates names and keys and notes keys no chosen technique
// reads from these alone (tests/test_technique_catalog.cpp checks that every key declared changes the
// image and every other key leaves it untouched).
//
// Which technique covers which casters: `shadows.<kind>` when the scene gives it, else
// `shadows.technique` when that takes the kind, else the kind's default (volumes cssm, spheres issm,
// isosurfaces light_pass, planes ray_traced). Each light's transmittance to a point is the product over
// the techniques so chosen (one per distinct name, each built from its kinds of caster only).
#pragma once

#include <string>
#include <string_view>
#include <vector>

#include "penumbra/lighting/technique_info.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

// Every registered technique (registry.h), shadows first, in registration order.
std::vector<const TechniqueInfo*> technique_catalog();
// The technique of that name, or nullptr.
const TechniqueInfo* find_technique(TechniqueFamily family, std::string_view name);
// Every name of the family ("none" first); those that take casters of `kind`.
std::vector<std::string> technique_names(TechniqueFamily family);
std::vector<std::string> technique_names(TechniqueFamily family, ObjectKind kind);
// The declaration of `key` among the family's techniques (they declare a shared key alike:
// register_technique refuses otherwise), or nullptr when no technique of the family reads it.
const ParamSpec* find_param(TechniqueFamily family, std::string_view key);
// The value of a declared key: the scene's, or its declared default. Error when no technique of the
// family declares it.
double param_number(TechniqueFamily family, const TechniqueParams& params, std::string_view key);
std::int64_t param_integer(TechniqueFamily family, const TechniqueParams& params, std::string_view key);
// Every key the family's techniques read, each once, in catalogue order.
std::vector<const ParamSpec*> family_params(TechniqueFamily family);

// The kinds of object in the scene that cast shadows, and those that receive them.
KindMask casting_kinds(const Scene& scene);
KindMask receiving_kinds(const Scene& scene);

// One shadow technique of a light and the kinds of caster it covers.
struct ShadowAssignment {
  std::string technique;
  KindMask casters;
};
// The shadow techniques that cover the scene's casting kinds (see above), in catalogue order of
// their kinds; empty when nothing casts. Throws Error naming `shadows.<kind>` for a technique that
// does not take that kind.
std::vector<ShadowAssignment> shadow_assignments(const Scene& scene);
// The kinds an ambient technique takes that the scene holds (its occluders).
KindMask ambient_occluders(const Scene& scene);

// Whether the scene's techniques read the extinction SAT, whether they need its colour table, and
// whether any traces rays through spheres.
bool needs_extinction_sat(const Scene& scene);
bool needs_extinction_colour(const Scene& scene);
bool needs_sphere_bvh(const Scene& scene);
// Whether the spheres are splatted (the splat rasterizer, or a technique that needs their order).
bool needs_sphere_order(const Scene& scene);

}  // namespace penumbra
