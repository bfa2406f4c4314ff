#include "penumbra/render/sphere_clipping.h"

#include <algorithm>

#include "penumbra/core/parallel.h"

namespace penumbra {

void clip_spheres(ParticleSet& set, const ClipPlanes& planes, std::span<const std::uint32_t> offsets,
                  const std::vector<bool>& clipped) {
  set.clip_planes = planes;
  set.clip_state.clear();
  if (planes.empty() || std::none_of(clipped.begin(), clipped.end(), [](bool c) { return c; })) {
    set.clip_state.shrink_to_fit();
    return;
  }
  set.clip_state.assign(set.size(), kSphereWhole);
  for (std::size_t k = 0; k + 1 < offsets.size() && k < clipped.size(); ++k) {
    if (!clipped[k]) continue;
    const std::size_t first = offsets[k], end = std::min<std::size_t>(offsets[k + 1], set.size());
    if (first >= end) continue;
    parallel_for(end - first, [&](std::size_t b, std::size_t e) {
      for (std::size_t i = first + b; i < first + e; ++i)
        set.clip_state[i] = planes.classify(set.spheres[i].center, set.spheres[i].radius);
    }, 16384);
  }
}

}  // namespace penumbra
