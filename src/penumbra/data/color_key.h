// What a particle set's colours mean, for legends (the viewer's, `--stats`): per colour drawn, the
// names it stands for (element symbols, chain ids, residue names) and how many spheres have it; for a
// scalar colouring, the quantity, its range and the colour map sampled over it. Names that share a
// colour (a palette that repeats, every non-standard residue in grey) share an entry, as a legend reads.
// And the periodic box a particle file stores, which viewers draw as an outline (VMD's `pbc box`).
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/data/transfer_function.h"

namespace penumbra {

struct ColorKey {
  struct Entry {
    std::string label;        // the names of this colour, most spheres first ("O", "SOL, NA, CL")
    std::uint32_t color = 0;  // pack_rgba8, linear RGB
    std::size_t count = 0;    // spheres of this colour
  };
  static constexpr std::size_t kRampSize = 32;
  static constexpr std::size_t kMaxNamesPerEntry = 4;  // more: "+k more"

  std::string by;              // "element", "chain", "residue", "uniform", "scalar", "hue"; "" unknown (arrays)
  std::vector<Entry> entries;  // element, chain, residue, uniform: most spheres first
  std::string quantity;        // scalar: "b_factor", "occupancy" or "index"
  float lo = 0, hi = 0;        // scalar: the range mapped
  std::vector<std::uint32_t> ramp;  // scalar: kRampSize colours from lo to hi (pack_rgba8)
};

// The key of a colouring by names: sphere k has colour colors[k] and the name numbered name_id(k);
// name(id) spells it.
ColorKey categorical_color_key(std::string by, const std::vector<std::uint32_t>& colors,
                               const std::function<std::uint32_t(std::size_t)>& name_id,
                               const std::function<std::string(std::uint32_t)>& name);
ColorKey scalar_color_key(std::string quantity, float lo, float hi, const TransferFunction& map);
// Counts again over `colors` (the spheres were picked or copied): entries no sphere has are dropped.
void recount(ColorKey& key, const std::vector<std::uint32_t>& colors);

// A periodic cell in world space: the parallelepiped origin + u·a + v·b + w·c, u, v, w in [0, 1].
struct PeriodicBox {
  Vec3 origin, a, b, c;
};

}  // namespace penumbra
