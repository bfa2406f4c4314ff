// Scene-file names of the isosurface shadow techniques and their factory.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "penumbra/isosurface/iso_shadow_technique.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

std::vector<std::string> isosurface_shadow_technique_names();  // "none", "light_pass", "ray_traced"
std::unique_ptr<IsoShadowTechnique> make_isosurface_shadow_technique(const ShadowSettings& settings);

}  // namespace penumbra
