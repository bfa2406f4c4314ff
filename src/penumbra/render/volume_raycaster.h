// Direct volume rendering by ray casting (Levoy 1988; Max 1995's emission–absorption model): one ray
// per pixel from a perspective camera, clipped to the volume's box and to the nearest opaque plane,
// sampled every Δ, classified by the transfer-function table, shaded with gradient Blinn–Phong under
// every light (each light's transmittance from its ShadowTechnique) and composited front to back.
// Each ray's samples sit on the lattice t = (k + j)·Δ with a per-pixel offset j (hashed, so
// deterministic) when the volume asks for jitter: this trades the wood-grain rings of thin opaque
// structures for fine noise, as VTK's UseJittering does. Empty macrocells are skipped and a ray stops once its opacity reaches kEarlyTermination. Planes are
// shaded as Lambertian receivers of the same lights and shadows. An ambient technique, when given,
// scales every sample's ambient term (ambient occlusion and colour bleeding).
#pragma once

#include <span>
#include <vector>

#include "penumbra/core/cutoffs.h"
#include "penumbra/core/image.h"
#include "penumbra/render/prepared_volume.h"
#include "penumbra/scene/scene.h"
#include "penumbra/shadows/ambient_technique.h"
#include "penumbra/shadows/shadow_technique.h"

namespace penumbra {

// Opaque surfaces drawn by another pass (spheres and planes): per pixel the distance along the primary
// ray and the shaded colour. Rays stop there and composite over that colour; the planes are then not
// drawn again.
struct OpaqueLayer {
  const std::vector<float>* distance;  // infinity: nothing opaque (the background shows)
  const Image* color;
};

struct RayCastInputs {
  const Scene* scene;
  const Camera* camera;
  const PreparedVolume* volume;                       // may be null (planes only)
  std::span<const Light> lights;
  std::span<const ShadowTechnique* const> shadows;    // one per light
  const AmbientTechnique* ambient = nullptr;          // scales the ambient term; null: unoccluded
  const OpaqueLayer* opaque = nullptr;                // null: the planes are traced here
};

Image render_volume_frame(const RayCastInputs& in);

}  // namespace penumbra
