// Scene-file names of the shadow and ambient techniques and their factories (one place to add one).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "penumbra/scene/scene.h"
#include "penumbra/shadows/ambient_technique.h"
#include "penumbra/shadows/shadow_technique.h"

namespace penumbra {

std::vector<std::string> shadow_technique_names();          // available in this build
std::unique_ptr<ShadowTechnique> make_shadow_technique(const ShadowSettings& settings);

std::vector<std::string> ambient_technique_names();          // available in this build ("none" first)
// nullptr for "none".
std::unique_ptr<AmbientTechnique> make_ambient_technique(const AmbientSettings& settings);

// Whether the scene's techniques read the extinction SAT, and whether they need its colour table.
bool needs_extinction_sat(const Scene& scene);
bool needs_extinction_colour(const Scene& scene);

}  // namespace penumbra
