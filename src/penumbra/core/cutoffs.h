// Where rays stop early: the cut-offs every pass shares, named once.
//
// An eye ray (volume ray casting) and an ambient-occlusion cone stop once their accumulated opacity
// reaches kEarlyTermination. A light ray stops once every channel's transmittance is below
// kShadowOpaque (OSPRay's "minContribution"), which for extinction techniques is an optical depth of
// kOpaqueDepth = −ln kShadowOpaque.
#pragma once

#include <cmath>

namespace penumbra {

constexpr float kEarlyTermination = 0.99f;
constexpr float kShadowOpaque = 1e-4f;
inline const double kOpaqueDepth = -std::log(static_cast<double>(kShadowOpaque));

}  // namespace penumbra
