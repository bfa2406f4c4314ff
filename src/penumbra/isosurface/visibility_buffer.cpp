#include "penumbra/isosurface/visibility_buffer.h"

#include <algorithm>
#include <bit>

namespace penumbra {

namespace {

// Bits of an 8x8 word whose cells (bx, by) lie in [bx0, bx1] x [by0, by1].
std::uint64_t rect_mask(int bx0, int by0, int bx1, int by1) {
  const std::uint64_t row = ((std::uint64_t{1} << (bx1 - bx0 + 1)) - 1) << bx0;
  std::uint64_t mask = 0;
  for (int by = by0; by <= by1; ++by) mask |= row << (by * 8);
  return mask;
}

}  // namespace

VisibilityBuffer::VisibilityBuffer(int width, int height, bool visible) : width_(width), height_(height) {
  int nx = (width + 7) / 8, ny = (height + 7) / 8;
  while (true) {
    words_x_.push_back(nx);
    words_y_.push_back(ny);
    words_.emplace_back(static_cast<std::size_t>(nx) * static_cast<std::size_t>(ny), 0);
    if (nx == 1 && ny == 1) break;
    nx = (nx + 7) / 8;
    ny = (ny + 7) / 8;
  }
  if (!visible) return;
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) words_[0][word_index(0, x >> 3, y >> 3)] |= std::uint64_t{1} << bit(x, y);
  for (std::size_t l = 1; l < words_.size(); ++l)
    for (int wy = 0; wy < words_y_[l - 1]; ++wy)
      for (int wx = 0; wx < words_x_[l - 1]; ++wx)
        if (words_[l - 1][word_index(static_cast<int>(l) - 1, wx, wy)] != 0)
          words_[l][word_index(static_cast<int>(l), wx >> 3, wy >> 3)] |= std::uint64_t{1} << bit(wx, wy);
}

void VisibilityBuffer::set_covered(int x, int y) {
  for (std::size_t l = 0; l < words_.size(); ++l) {
    std::uint64_t& w = words_[l][word_index(static_cast<int>(l), x >> 3, y >> 3)];
    w &= ~(std::uint64_t{1} << bit(x, y));
    if (w != 0) return;  // the levels above still see a visible pixel here
    x >>= 3;
    y >>= 3;
  }
}

void VisibilityBuffer::set_visible(int x, int y) {
  for (std::size_t l = 0; l < words_.size(); ++l) {
    std::uint64_t& w = words_[l][word_index(static_cast<int>(l), x >> 3, y >> 3)];
    const bool was_empty = w == 0;
    w |= std::uint64_t{1} << bit(x, y);
    if (!was_empty) return;
    x >>= 3;
    y >>= 3;
  }
}

bool VisibilityBuffer::any_visible(int x0, int y0, int x1, int y1) const {
  x0 = std::max(x0, 0);
  y0 = std::max(y0, 0);
  x1 = std::min(x1, width_ - 1);
  y1 = std::min(y1, height_ - 1);
  if (x0 > x1 || y0 > y1) return false;
  return query(static_cast<int>(words_.size()) - 1, 0, 0, x0, y0, x1, y1);
}

// Word (wx, wy) of `level` covers pixels [wx, wx + 1) * 8^(level+1) (and likewise in y); each of its
// bits a square of 8^level pixels.
bool VisibilityBuffer::query(int level, int wx, int wy, int x0, int y0, int x1, int y1) const {
  const std::uint64_t word = words_[static_cast<std::size_t>(level)][word_index(level, wx, wy)];
  if (word == 0) return false;
  const int shift = 3 * level;  // log2 of a bit's side in pixels
  const int ox = wx << 3, oy = wy << 3;  // the word's first bit cell, in units of 8^level pixels
  const int bx0 = std::max((x0 >> shift) - ox, 0), bx1 = std::min((x1 >> shift) - ox, 7);
  const int by0 = std::max((y0 >> shift) - oy, 0), by1 = std::min((y1 >> shift) - oy, 7);
  if (bx0 > bx1 || by0 > by1) return false;
  std::uint64_t hits = word & rect_mask(bx0, by0, bx1, by1);
  if (level == 0 || hits == 0) return hits != 0;
  const int side = 1 << shift;
  while (hits != 0) {
    const int b = std::countr_zero(hits);
    hits &= hits - 1;
    const int cx = ox + (b & 7), cy = oy + (b >> 3);  // child word
    // A child wholly inside the rectangle with a set bit has a visible pixel inside it.
    if (cx * side >= x0 && (cx + 1) * side - 1 <= x1 && cy * side >= y0 && (cy + 1) * side - 1 <= y1) return true;
    if (query(level - 1, cx, cy, x0, y0, x1, y1)) return true;
  }
  return false;
}

std::size_t VisibilityBuffer::visible_count() const {
  std::size_t n = 0;
  for (std::uint64_t w : words_[0]) n += static_cast<std::size_t>(std::popcount(w));
  return n;
}

}  // namespace penumbra
