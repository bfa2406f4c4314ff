// A linear-RGB float image and its comparison metrics.
#pragma once

#include <string>
#include <vector>

#include "penumbra/core/color.h"

namespace penumbra {

class Image {
public:
  Image() = default;
  Image(int width, int height, Rgb fill = Rgb(0.0f))
      : width_(width), height_(height), pixels_(static_cast<std::size_t>(width) * height, fill) {}
  int width() const { return width_; }
  int height() const { return height_; }
  Rgb& at(int x, int y) { return pixels_[static_cast<std::size_t>(y) * width_ + x]; }
  const Rgb& at(int x, int y) const { return pixels_[static_cast<std::size_t>(y) * width_ + x]; }
  const std::vector<Rgb>& pixels() const { return pixels_; }
  std::vector<Rgb>& pixels() { return pixels_; }

private:
  int width_ = 0, height_ = 0;
  std::vector<Rgb> pixels_;
};

struct ImageDifference {
  double rmse = 0;   // over all channels, on values clamped to [0, 1]
  double psnr = 0;   // 20 log10(1 / rmse) in dB; infinity for identical images
  double max_abs = 0;
};

// Compares two images of equal size (throws Error otherwise). Values are clamped to [0, 1] first,
// so that float and 8-bit images of the same picture compare alike.
ImageDifference compare_images(const Image& a, const Image& b);

// False-colour map of the per-pixel difference: black = equal, through blue and yellow to red = `scale`.
Image difference_image(const Image& a, const Image& b, float scale);

// Images side by side, left to right, 4 white pixels apart; shorter images are padded with white.
Image montage(const std::vector<const Image*>& images);

}  // namespace penumbra
