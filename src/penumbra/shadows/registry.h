// Scene-file names of the shadow techniques and their factories (one place to add a technique).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "penumbra/scene/scene.h"
#include "penumbra/shadows/shadow_technique.h"

namespace penumbra {

std::vector<std::string> shadow_technique_names();          // available in this build
std::vector<std::string> planned_shadow_technique_names();  // reserved names of other casters' techniques
std::unique_ptr<ShadowTechnique> make_shadow_technique(const ShadowSettings& settings);

}  // namespace penumbra
