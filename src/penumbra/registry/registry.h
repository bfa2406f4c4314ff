// The one registry of shadow and ambient techniques. Each technique declares itself in its own file
// (lighting/technique_info.h: name, kinds, keys with their types, defaults, ranges and meanings, and a
// factory) and takes one line in registry.cpp. register_technique adds one at run time (a test's or a
// plug-in's): it is then read from scene files, validated, listed, documented and built like the rest.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "penumbra/lighting/ambient_technique.h"
#include "penumbra/lighting/shadow_technique.h"
#include "penumbra/lighting/technique_info.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

// Every technique, shadows first, "none" first in each family, then in registration order.
std::vector<const TechniqueInfo*> registered_techniques();

// Adds a technique; `info` must outlive its registration (a static). Throws Error when the family
// already has a technique of that name, when the factory of its family is missing, or when it
// declares a key that another technique of the family declares differently (a key means one thing).
void register_technique(const TechniqueInfo& info);
// Removes a technique register_technique added (the built-in ones stay); false when there was none.
bool unregister_technique(TechniqueFamily family, const std::string& name);

std::unique_ptr<ShadowTechnique> make_shadow_technique(const std::string& name, const ShadowSettings& settings);
inline std::unique_ptr<ShadowTechnique> make_shadow_technique(const ShadowSettings& settings) {
  return make_shadow_technique(settings.technique, settings);
}

// nullptr for "none".
std::unique_ptr<AmbientTechnique> make_ambient_technique(const AmbientSettings& settings);

}  // namespace penumbra
