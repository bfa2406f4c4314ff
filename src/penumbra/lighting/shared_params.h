// Keys that several techniques read with one meaning, declared once (lighting/technique_info.h): the
// light-space maps' side and depth bias (the three shadow maps, the ISSM, the light pass), the light
// rays' sampling step, and the reach of ambient occlusion among spheres.
#pragma once

#include "penumbra/lighting/technique_info.h"

namespace penumbra {

// Light rays sample volumes once per voxel unless shadows.step says otherwise.
constexpr float kDefaultShadowStepVoxels = 1.0f;

inline const ParamSpec kMapResolution =
    integer_param("resolution", 1024, 16, 16384, "texels", "shadow map texels per side", ParamRole::MapSide);

inline const ParamSpec kMapBias = [] {
  ParamSpec p = number_param("bias", -1, 0, 1e6, "world units", "depth bias between a receiver and the depth the map stores; -1: automatic (the maps: one light step; the light pass: the points' position errors and one light pixel)");
  p.also = {-1};
  return p;
}();

inline const ParamSpec kLightStep = [] {
  ParamSpec p = number_param("step", -1, 0.05, 8, "voxels", "light-ray sampling step; -1: one voxel", ParamRole::LightStep);
  p.also = {-1};
  return p;
}();

// The light step in voxels (kLightStep, -1 resolved).
inline float light_step_voxels(const TechniqueParams& params) {
  const double step = kLightStep.number(params);
  return step > 0 ? static_cast<float>(step) : kDefaultShadowStepVoxels;
}

inline const ParamSpec kAoMaxDistance =
    number_param("max_distance", 0.7, 1e-6, 10, "of the spheres' longest side", "reach of the occlusion");

}  // namespace penumbra
