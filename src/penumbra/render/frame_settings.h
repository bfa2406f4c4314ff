// The scene a frame's light structures are built from, when it is not the scene itself: a preview's
// coarser settings (the roles the techniques declare for their keys: map sides, light steps, ray
// counts) and an accumulated sample's seed.
#pragma once

#include "penumbra/lighting/technique_info.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

// The scene's settings for a preview: coarser shadow maps, a half-resolution light cache, light steps
// twice as long, a quarter of the rays of the ray-traced techniques. (The eye step doubles too:
// PreparedVolume's preview table.) The maps take a quarter of the full resolution, or less where the
// last full build of the lights (full_shadow_ms, 0: not known) says a quarter would miss the target:
// build time grows with the texels, so the side shrinks with the square root; never below 64.
Scene preview_settings(const Scene& scene, double full_shadow_ms);

// The seed key of the scene's shadow techniques (the one accumulated samples move), or nullptr.
const ParamSpec* seed_param(const Scene& s);

}  // namespace penumbra
