// The viewer's probe (docs/viewer.md, {"type": "probe"}): what lies under a pixel of the view. The
// pixel's primary ray is marched through each visible volume at its sampling step; the answer is the
// nearest sample whose transfer-function opacity exceeds kProbeAlpha (the first thing the eye sees
// there), with its value, volume and position. Clip planes that cut a volume are honoured.
#pragma once

#include <nlohmann/json.hpp>

#include <utility>

#include "penumbra/scene/scene.h"

namespace penumbra {

constexpr float kProbeAlpha = 0.01f;

// {"type": "probe", "pixel": [x, y], "hit": true, "volume": i, "value": v, "position": [x, y, z]}, or
// "hit": false when the ray meets nothing visible. (x, y) are in the camera's pixels (camera.width ×
// camera.height, the view's size), from the top left.
nlohmann::json probe_message(const Scene& scene, float x, float y);

// The pixel of a probe request {"type": "probe", "pixel": [x, y]}: two finite numbers within ±1e6, or
// an Error saying so.
std::pair<float, float> probe_pixel(const nlohmann::json& message);

}  // namespace penumbra
