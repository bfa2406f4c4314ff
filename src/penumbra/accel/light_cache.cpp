#include "penumbra/accel/light_cache.h"

#include "penumbra/core/error.h"

namespace penumbra {

LightCache::LightCache(const CellLattice& lattice, bool ambient, std::size_t lights)
    : lattice_(lattice),
      ambient_(ambient),
      lights_(lights),
      channels_((ambient ? 3 : 0) + static_cast<int>(lights)),
      stride_(channels_ <= 4 ? 4 : 8) {
  if (channels_ > kMaxChannels) throw Error("light cache: more than " + std::to_string(kMaxChannels) + " channels");
  values_.assign(lattice_.cell_count() * static_cast<std::size_t>(stride_), 0.0f);
}

void LightCache::set_ambient(const CellField<Rgb>& source) {
  if (!ambient_ || !source.lattice().same_cells(lattice_)) throw Error("light cache: the ambient term does not fit");
  const auto stride = static_cast<std::size_t>(stride_);
  parallel_for(source.size(), [&](std::size_t c0, std::size_t c1) {
    for (std::size_t c = c0; c < c1; ++c) {
      values_[c * stride] = source[c].r;
      values_[c * stride + 1] = source[c].g;
      values_[c * stride + 2] = source[c].b;
    }
  });
}

void LightCache::set_light(std::size_t slot, const CellField<float>& source) {
  if (slot >= lights_ || !source.lattice().same_cells(lattice_)) throw Error("light cache: a light's term does not fit");
  const auto stride = static_cast<std::size_t>(stride_);
  const auto channel = static_cast<std::size_t>(light_channel(slot));
  parallel_for(source.size(), [&](std::size_t c0, std::size_t c1) {
    for (std::size_t c = c0; c < c1; ++c) values_[c * stride + channel] = source[c];
  });
}

}  // namespace penumbra
