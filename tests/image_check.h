// What an image test leaves behind when it fails (the habit of OSPRay's test suite): the rendered
// image, the reference and a false-colour difference, as PNGs named after the test, in
// $PENUMBRA_TEST_OUTPUT or else the working directory (ctest runs tests in the build directory).
//
//   FailureImages keep;                       // one per test, before the checks
//   keep.add("cssm", image, reference);       // every comparison the test makes
//   EXPECT_GT(compare_images(image, reference).psnr, floor);
//   // on failure, ~FailureImages writes <suite>.<test>.cssm.{rendered,reference,difference}.png
#pragma once

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/core/image.h"
#include "penumbra/core/image_io.h"

namespace penumbra::test {

// Where failing image tests write their images.
inline std::filesystem::path test_output_dir() {
  const char* d = std::getenv("PENUMBRA_TEST_OUTPUT");
  return d != nullptr && *d != '\0' ? std::filesystem::path(d) : std::filesystem::current_path();
}

// Writes rendered, reference and difference images of `tag` for the running test; returns the file
// stem. Used by FailureImages, callable directly too.
inline std::string write_failure_images(const std::string& tag, const Image& rendered, const Image& reference) {
  const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
  std::string stem = info != nullptr ? std::string(info->test_suite_name()) + "." + info->name() : "test";
  stem += "." + tag;
  for (char& c : stem)
    if (c == '/' || c == ' ') c = '_';
  const std::filesystem::path dir = test_output_dir();
  std::error_code ec;
  std::filesystem::create_directories(dir, ec);
  const std::string base = (dir / stem).string();
  try {
    write_image(base + ".rendered.png", rendered);
    if (reference.width() > 0) write_image(base + ".reference.png", reference);
    if (reference.width() == rendered.width() && reference.height() == rendered.height()) {
      // the scale is the largest difference, so that the worst pixel is red whatever its size
      const float scale = std::max(1e-6f, static_cast<float>(compare_images(rendered, reference).max_abs));
      write_image(base + ".difference.png", difference_image(rendered, reference, scale));
    }
    std::printf("[  images  ] wrote %s.%s.png\n", base.c_str(), reference.width() > 0 ? "{rendered,reference,difference}" : "rendered");
  } catch (const std::exception& e) {
    std::printf("[  images  ] could not write %s: %s\n", base.c_str(), e.what());
  }
  return base;
}

// Keeps copies of the image pairs a test compares and writes them all when the test has failed.
class FailureImages {
public:
  FailureImages() = default;
  FailureImages(const FailureImages&) = delete;
  FailureImages& operator=(const FailureImages&) = delete;
  ~FailureImages() {
    if (!::testing::Test::HasFailure()) return;
    for (const auto& [tag, pair] : pairs_) write_failure_images(tag, pair.first, pair.second);
  }
  // `reference` may be empty (Image{}) where a test checks one image on its own.
  void add(const std::string& tag, const Image& rendered, const Image& reference) {
    pairs_.emplace_back(tag, std::make_pair(rendered, reference));
  }

private:
  std::vector<std::pair<std::string, std::pair<Image, Image>>> pairs_;
};

// True when the image is not blank: at least two clearly different pixel colours (max channel
// difference > 0.02, five 8-bit steps) and some pixel brighter than 0.02.
// The largest difference of any channel of any pixel.
inline double max_difference(const Image& a, const Image& b) {
  double d = 0;
  for (std::size_t i = 0; i < a.pixels().size(); ++i) {
    const Rgb e = a.pixels()[i] - b.pixels()[i];
    d = std::max({d, double(std::abs(e.r)), double(std::abs(e.g)), double(std::abs(e.b))});
  }
  return d;
}

inline bool non_trivial(const Image& img) {
  if (img.pixels().empty()) return false;
  const Rgb first = img.pixels().front();
  bool varies = false, bright = false;
  for (const Rgb& p : img.pixels()) {
    varies = varies || std::abs(p.r - first.r) > 0.02f || std::abs(p.g - first.g) > 0.02f || std::abs(p.b - first.b) > 0.02f;
    bright = bright || std::max({p.r, p.g, p.b}) > 0.02f;
  }
  return varies && bright;
}

}  // namespace penumbra::test
