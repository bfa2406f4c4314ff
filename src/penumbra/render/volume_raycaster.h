// Direct volume rendering by ray casting (Levoy 1988; Max 1995's emission–absorption model): one ray
// per pixel from a perspective camera, clipped to the visible volumes' boxes and to the opaque layer
// (the spheres, isosurfaces and planes drawn before), sampled every Δ, classified by each volume's
// transfer-function table, shaded with gradient Blinn–Phong under every light (each light's
// transmittance from its LightShadows) and composited front to back over the opaque layer's colour.
// Each ray's samples sit on the lattice t = (k + j)·Δ with a per-pixel offset j (hashed, so
// deterministic) when a volume asks for jitter: this trades the wood-grain rings of thin opaque
// structures for fine noise, as VTK's UseJittering does. Empty macrocells are skipped and a ray stops
// once its opacity reaches kEarlyTermination. An ambient technique, when given, scales every sample's
// ambient term (ambient occlusion and colour bleeding).
//
// Overlapping volumes share one lattice (Δ the finest of their steps, every volume tabulated for it)
// and are sampled at the same positions: a sample's opacity is 1 − Π(1 − α_v), shared among the
// volumes in proportion to their α_v, each part shaded with its own colour and gradient — so two
// volumes with disjoint support render as one volume holding both. Compositing modes mix: each
// volume's α_v is read in its own mode (alpha or extinction) before they combine.
//
// With a packed light cache (accel/light_cache.h) a sample reads the ambient term and the shadows of
// every cached light with one fetch; the other lights are asked per batch as usual. With a SampleSlab
// only the samples that slab owns are composited (sort-last bricks, distributed/volume_slabs.h).
#pragma once

#include <span>
#include <vector>

#include "penumbra/accel/light_cache.h"
#include "penumbra/core/cutoffs.h"
#include "penumbra/core/image.h"
#include "penumbra/core/sample_slab.h"
#include "penumbra/render/light_shadows.h"
#include "penumbra/render/prepared_volume.h"
#include "penumbra/scene/scene.h"
#include "penumbra/lighting/ambient_technique.h"

namespace penumbra {

// Opaque surfaces drawn by another pass (spheres, isosurfaces and planes): per pixel the distance along
// the primary ray and the shaded colour. Rays stop there and composite over that colour.
struct OpaqueLayer {
  const std::vector<float>* distance;  // infinity: nothing opaque (the background shows)
  const Image* color;
};

// Translucent planes (slices with opacity below 1) in front of the opaque layer: per pixel the distance
// (infinity: none), the shaded colour and the opacity. A ray composites the volumes up to the plane, the
// plane over what lies behind it, and the volumes from the plane to the opaque layer.
struct TranslucentLayer {
  const std::vector<float>* distance;
  const Image* color;
  const std::vector<float>* opacity;
};

struct RayCastInputs {
  const Scene* scene;
  const Camera* camera;
  std::span<const PreparedVolume* const> volumes;    // the visible volumes, on one lattice step
  std::span<const Light> lights;
  std::span<const LightShadows* const> shadows;      // one per light
  const AmbientTechnique* ambient = nullptr;          // scales the ambient term; null: unoccluded
  // The packed light cache (paper 001): one fetch per sample for the ambient term (when it holds it)
  // and for every light whose slot is ≥ 0 (cached_light_slot, one per light); null: none.
  const LightCache* light_cache = nullptr;
  std::span<const int> cached_light_slot;
  const OpaqueLayer* opaque = nullptr;
  const TranslucentLayer* translucent = nullptr;
  std::uint32_t sample = 0;  // accumulation sample: 0 the batch frame; others move every pixel's jitter
  const SampleSlab* owned = nullptr;  // a brick's samples only; null: every sample
  // One volume: a finer box of it (render/view_refinement.h), drawn where a ray crosses it, the volume
  // before and behind it on the same lattice; null: none.
  const PreparedVolume* refined = nullptr;
};

struct VolumeFrame {
  Image image;                     // the volumes composited over the opaque layer (or the background)
  std::vector<float> opacity;      // per pixel: the volumes' accumulated opacity in front of the opaque layer
  std::vector<float> half_depth;   // per pixel: where that opacity first reaches 1/2; infinity: never
  std::size_t samples = 0;         // lattice samples classified (a value fetched and looked up), over every ray
  std::size_t shaded_samples = 0;  // of which visible, so shaded (normal, lights, ambient)
};

VolumeFrame render_volume_frame(const RayCastInputs& in);

}  // namespace penumbra
