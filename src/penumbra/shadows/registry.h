// Factories of the volume shadow and ambient techniques (their names and keys are in
// scene/technique_catalog.h).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "penumbra/scene/scene.h"
#include "penumbra/shadows/ambient_technique.h"
#include "penumbra/shadows/shadow_technique.h"

namespace penumbra {

std::unique_ptr<ShadowTechnique> make_shadow_technique(const ShadowSettings& settings);

// nullptr for "none".
std::unique_ptr<AmbientTechnique> make_ambient_technique(const AmbientSettings& settings);

}  // namespace penumbra
