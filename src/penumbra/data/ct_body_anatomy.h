// The anatomy of "ct-body" (ct_body.h) as a painting list: every structure is an ellipsoid or a stack of
// elliptic cross-sections, painted in order over what lies beneath (skin, then fat, then muscle, then
// organs, bones and blobs). Heights h are millimetres above the box's bottom (world z = h - 867).
#pragma once

#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

namespace penumbra::ct_anatomy {

constexpr double kFov = 500;      // mm across x and y
constexpr double kLength = 1734;  // mm along z
constexpr double kInf = std::numeric_limits<double>::infinity();

// An elliptic cross-section at height h: centre (cx, cy) and semi-axes (a, b).
struct Knot {
  double h = 0, cx = 0, cy = 0, a = 0, b = 0;
};

struct Point {
  double x = 0, y = 0, h = 0;
};

// One structure: an ellipsoid (no knots), or cross-sections interpolated linearly between knots
// (sorted by h; flat, anti-aliased caps at both ends). `inset` shrinks every semi-axis (and moves a
// stack's caps inwards); shell > 0 paints only the outer band of that thickness, open at a stack's caps.
// The clip box cuts it (hard in x and y, anti-aliased in h).
struct Item {
  std::vector<Knot> knots;
  Point centre, axes;
  float value = 0;
  double inset = 0, shell = 0;
  double xmin = -kInf, xmax = kInf, ymin = -kInf, ymax = kInf, hmin = -kInf, hmax = kInf;
};

// The painting list; `seed` places the blobs (calcifications, lung vessels, bowel loops and gas).
std::vector<Item> build(std::uint64_t seed);

// The cross-section at height h with the semi-axes reduced by `inset`; false where there is none.
bool section(const Item& it, double h, double inset, Knot& out);

// How much of a slice `step` thick at height h lies inside the item's extent in h (its flat caps and clip).
double cover(const Item& it, double h, double step);

// The heights [lo, hi] the item spans.
std::pair<double, double> height_range(const Item& it);

// The torso's cross-section at height h (clamped to its ends).
Knot torso_at(double h);

}  // namespace penumbra::ct_anatomy
