// What the viewer's page needs to draw its controls (docs/viewer.md, the "state" message): the
// document, the resolved camera, each volume's histogram and resolved transfer function, and the
// techniques with the keys each reads.
#pragma once

#include <nlohmann/json.hpp>

#include <map>

#include "penumbra/engine/engine.h"

namespace penumbra {

class ViewerState {
public:
  // The state message for the engine's current scene. Histograms are computed once per volume data.
  nlohmann::json message(const Engine& engine);

private:
  std::map<const Volume*, nlohmann::json> histograms_;
};

}  // namespace penumbra
