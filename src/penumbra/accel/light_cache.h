// Paper 001's light cache texture T (§3, Algorithm 1): "the summation terms for AO/color bleeding and
// the directional shadows in the different channels of the texture ... fetched from the texture with a
// single lookup". The ambient technique (sat_shells, sampled_ao) and each cached light's sat_cone
// keep their own CellField; this packs them, interleaved per cell, so that a volume sample reads every
// term with one trilinear fetch: the eight corner cells once, instead of once per term.
//
// Channels: the ambient term's red, green and blue when it is packed, then one attenuation per packed
// light. A light whose shadows are rebuilt (it moved) or an ambient term rebuilt (the transfer
// function changed) replaces only its channels, as the paper recomputes only "the part of the light
// cache texture containing the values for the directional shadows".
//
// Interpolation is CellField's, channel by channel in the same order, so a packed fetch returns the
// same floats as the separate fetches it replaces (the images are byte-identical).
#pragma once

#include <cstddef>
#include <vector>

#include "penumbra/accel/cell_field.h"

namespace penumbra {

class LightCache {
public:
  static constexpr int kMaxChannels = 8;

  // The layout: the ambient term packed or not, and `lights` packed lights (at most kMaxChannels − 3).
  LightCache(const CellLattice& lattice, bool ambient, std::size_t lights);

  // Copies a source into its channels; `source` must be on this cache's lattice.
  void set_ambient(const CellField<Rgb>& source);
  void set_light(std::size_t slot, const CellField<float>& source);

  const CellLattice& lattice() const { return lattice_; }
  bool has_ambient() const { return ambient_; }
  std::size_t light_count() const { return lights_; }
  int channels() const { return channels_; }
  // The channel of packed light `slot`.
  int light_channel(std::size_t slot) const { return (ambient_ ? 3 : 0) + static_cast<int>(slot); }
  std::size_t memory_bytes() const { return values_.size() * sizeof(float); }

  // Every channel at p (out[kMaxChannels], the first channels() meaningful); false when p lies outside
  // the box or next to a cell the sources left unfilled (the callers then ask the techniques themselves).
  bool try_fetch(const Vec3& p, float* out) const {
    if (!lattice_.bounds.contains(p)) return false;
    if (stride_ == 4) fetch<4>(p, out);
    else fetch<8>(p, out);
    bool ok = true;
    for (int ch = 0; ch < channels_; ++ch) ok = ok && !std::isnan(out[ch]);
    return ok;
  }

private:
  CellLattice lattice_;
  bool ambient_;
  std::size_t lights_;
  int channels_;
  int stride_;                 // floats per cell: 4 (the paper's RGBA) or 8, so the channels interpolate as vectors
  std::vector<float> values_;  // cell-major: stride_ floats per cell, the channels first, then zeros

  template <int N>
  void fetch(const Vec3& p, float* out) const {
    const CellCorners c = lattice_.corners(p);
    const float* v[8];
    for (int n = 0; n < 8; ++n) v[n] = &values_[c.index(lattice_.dims[0], lattice_.dims[1], n & 1, n & 2, n & 4) * N];
    const float t0 = c.t[0], t1 = c.t[1], t2 = c.t[2];
    for (int ch = 0; ch < N; ++ch) {
      const float x00 = v[0][ch] * (1 - t0) + v[1][ch] * t0;
      const float x10 = v[2][ch] * (1 - t0) + v[3][ch] * t0;
      const float x01 = v[4][ch] * (1 - t0) + v[5][ch] * t0;
      const float x11 = v[6][ch] * (1 - t0) + v[7][ch] * t0;
      const float y0 = x00 * (1 - t1) + x10 * t1;
      const float y1 = x01 * (1 - t1) + x11 * t1;
      out[ch] = y0 * (1 - t2) + y1 * t2;
    }
  }
};

}  // namespace penumbra
