// Factory of the isosurface shadow techniques (their names and keys are in scene/technique_catalog.h).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "penumbra/isosurface/iso_shadow_technique.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

std::unique_ptr<IsoShadowTechnique> make_isosurface_shadow_technique(const ShadowSettings& settings);

}  // namespace penumbra
