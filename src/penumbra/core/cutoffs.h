// Where rays stop early: the cut-offs every pass shares, named once.
//
// An eye ray (volume ray casting) and an ambient-occlusion cone stop once their accumulated opacity
// reaches kEarlyTermination. A light ray stops once every channel's transmittance is below
// kShadowOpaque (OSPRay's "minContribution"), which for extinction techniques is an optical depth of
// kOpaqueDepth = −ln kShadowOpaque.
#pragma once

namespace penumbra {

constexpr float kEarlyTermination = 0.99f;
constexpr float kShadowOpaque = 1e-4f;
// A constant, not a call: the cone loops compare against it once per cuboid (tests/test_core.cpp
// checks it equals −ln kShadowOpaque).
constexpr double kOpaqueDepth = 9.2103403972383084;  // of the float 1e-4f

}  // namespace penumbra
