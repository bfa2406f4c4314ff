// The one registry of shadow and ambient techniques, for every kind of caster (their names, the kinds
// they take and the keys they read are in registry/technique_catalog.h).
#pragma once

#include <memory>
#include <string>

#include "penumbra/scene/scene.h"
#include "penumbra/lighting/ambient_technique.h"
#include "penumbra/lighting/shadow_technique.h"

namespace penumbra {

std::unique_ptr<ShadowTechnique> make_shadow_technique(const std::string& name, const ShadowSettings& settings);
inline std::unique_ptr<ShadowTechnique> make_shadow_technique(const ShadowSettings& settings) {
  return make_shadow_technique(settings.technique, settings);
}

// nullptr for "none".
std::unique_ptr<AmbientTechnique> make_ambient_technique(const AmbientSettings& settings);

}  // namespace penumbra
