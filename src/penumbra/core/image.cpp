#include "penumbra/core/image.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "penumbra/core/error.h"

namespace penumbra {

ImageDifference compare_images(const Image& a, const Image& b) {
  if (a.width() != b.width() || a.height() != b.height())
    throw Error("images differ in size: " + std::to_string(a.width()) + "x" + std::to_string(a.height()) +
                " vs " + std::to_string(b.width()) + "x" + std::to_string(b.height()));
  double sum = 0, max_abs = 0;
  for (std::size_t i = 0; i < a.pixels().size(); ++i)
    for (int c = 0; c < 3; ++c) {
      const double d = std::clamp(a.pixels()[i][c], 0.0f, 1.0f) - std::clamp(b.pixels()[i][c], 0.0f, 1.0f);
      sum += d * d;
      max_abs = std::max(max_abs, std::abs(d));
    }
  ImageDifference r;
  const double n = 3.0 * static_cast<double>(std::max<std::size_t>(1, a.pixels().size()));
  r.rmse = std::sqrt(sum / n);
  r.psnr = r.rmse > 0 ? 20.0 * std::log10(1.0 / r.rmse) : std::numeric_limits<double>::infinity();
  r.max_abs = max_abs;
  return r;
}

Image difference_image(const Image& a, const Image& b, float scale) {
  if (a.width() != b.width() || a.height() != b.height()) throw Error("images differ in size");
  Image out(a.width(), a.height());
  for (std::size_t i = 0; i < a.pixels().size(); ++i) {
    float d = 0;
    for (int c = 0; c < 3; ++c)
      d = std::max(d, std::abs(std::clamp(a.pixels()[i][c], 0.0f, 1.0f) - std::clamp(b.pixels()[i][c], 0.0f, 1.0f)));
    const float t = std::clamp(d / std::max(scale, 1e-6f), 0.0f, 1.0f);
    // black -> blue -> yellow -> red
    Rgb c = t < 0.33f   ? Rgb(0, 0, t / 0.33f)
            : t < 0.66f ? Rgb((t - 0.33f) / 0.33f, (t - 0.33f) / 0.33f, 1.0f - (t - 0.33f) / 0.33f)
                        : Rgb(1, 1.0f - (t - 0.66f) / 0.34f, 0);
    out.pixels()[i] = c;
  }
  return out;
}

Image montage(const std::vector<const Image*>& images) {
  if (images.empty()) return {};
  constexpr int kGap = 4;
  int width = -kGap, height = 0;
  for (const Image* im : images) {
    width += im->width() + kGap;
    height = std::max(height, im->height());
  }
  Image out(width, height, Rgb(1.0f));
  int x0 = 0;
  for (const Image* im : images) {
    for (int y = 0; y < im->height(); ++y)
      for (int x = 0; x < im->width(); ++x) out.at(x0 + x, y) = im->at(x, y);
    x0 += im->width() + kGap;
  }
  return out;
}

}  // namespace penumbra
