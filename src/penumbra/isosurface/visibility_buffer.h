// The 1-bit visibility framebuffer of PIsA (paper 002 §3.1.2), with a hierarchy for fast "is any pixel
// of this rectangle still visible?" queries. Level 0 packs 8x8 pixels into one 64-bit word; every
// level above packs 8x8 words of the level below, one bit each ("some pixel under me is visible"), up
// to a single word. A query descends only into set bits that overlap the rectangle, so a rectangle
// over covered screen costs a few word tests whatever its size. Marking a pixel covered clears its bit
// and the bits above that became empty; punching a hole (§4.2) sets them again.
#pragma once

#include <cstdint>
#include <vector>

namespace penumbra {

class VisibilityBuffer {
public:
  VisibilityBuffer() = default;
  // All pixels visible (`visible` true: the eye pass) or all non-visible (the light pass, §4.2).
  VisibilityBuffer(int width, int height, bool visible);

  int width() const { return width_; }
  int height() const { return height_; }
  bool visible(int x, int y) const {
    return (level0()[word_index(0, x >> 3, y >> 3)] >> bit(x, y)) & 1u;
  }
  void set_covered(int x, int y);  // F(x) = non-visible: a point was extracted here
  void set_visible(int x, int y);  // F(x) = visible: a hole punched by an eye point (§4.2)
  // True when some pixel of the inclusive rectangle [x0, x1] x [y0, y1] (clipped to the image) is visible.
  bool any_visible(int x0, int y0, int x1, int y1) const;
  std::size_t visible_count() const;

private:
  static int bit(int x, int y) { return ((y & 7) << 3) | (x & 7); }
  const std::vector<std::uint64_t>& level0() const { return words_[0]; }
  std::size_t word_index(int level, int wx, int wy) const {
    return static_cast<std::size_t>(wy) * static_cast<std::size_t>(words_x_[static_cast<std::size_t>(level)]) + static_cast<std::size_t>(wx);
  }
  bool query(int level, int wx, int wy, int x0, int y0, int x1, int y1) const;

  int width_ = 0, height_ = 0;
  std::vector<std::vector<std::uint64_t>> words_;  // per level, row-major words
  std::vector<int> words_x_, words_y_;             // words per row / column of each level
};

}  // namespace penumbra
