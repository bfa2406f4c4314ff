#include "penumbra/core/exr_io.h"

#include <OpenEXR/ImfChannelList.h>
#include <OpenEXR/ImfFrameBuffer.h>
#include <OpenEXR/ImfHeader.h>
#include <OpenEXR/ImfInputFile.h>
#include <OpenEXR/ImfOutputFile.h>

#include <filesystem>
#include <limits>

#include "penumbra/core/error.h"
#include "penumbra/core/replace_file.h"

namespace penumbra {
namespace {

constexpr const char* kRgba[4] = {"R", "G", "B", "A"};

Imf::Slice float_slice(float* base, std::size_t x_stride, int width, float fill = 0.0f) {
  return Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(base), x_stride * sizeof(float),
                    x_stride * sizeof(float) * static_cast<std::size_t>(width), 1, 1, fill);
}

void write_exr_file(const std::string& path, const ExrImage& image) {
  Imf::Header header(image.width, image.height);
  header.compression() = Imf::ZIP_COMPRESSION;
  Imf::FrameBuffer fb;
  // OpenEXR writes from non-const pointers; nothing is modified.
  float* rgba = const_cast<float*>(image.rgba.data());
  for (int c = 0; c < 4; ++c) {
    header.channels().insert(kRgba[c], Imf::Channel(Imf::FLOAT));
    fb.insert(kRgba[c], float_slice(rgba + c, 4, image.width));
  }
  if (!image.depth.empty()) {
    header.channels().insert("Z", Imf::Channel(Imf::FLOAT));
    fb.insert("Z", float_slice(const_cast<float*>(image.depth.data()), 1, image.width));
  }
  Imf::OutputFile file(path.c_str(), header);
  file.setFrameBuffer(fb);
  file.writePixels(image.height);
}

}  // namespace

void write_exr(const std::string& path, const ExrImage& image) {
  with_context(path, [&] {
    const std::size_t pixels = static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height);
    if (image.width <= 0 || image.height <= 0) throw Error("image is empty");
    if (image.rgba.size() != 4 * pixels) throw Error("RGBA holds " + std::to_string(image.rgba.size()) + " floats; expected " + std::to_string(4 * pixels));
    if (!image.depth.empty() && image.depth.size() != pixels)
      throw Error("depth holds " + std::to_string(image.depth.size()) + " floats; expected " + std::to_string(pixels));
    replace_file(path, [&](const std::string& temporary) {
      try {
        write_exr_file(temporary, image);
      } catch (const std::exception& e) {
        throw Error(std::string("OpenEXR could not write: ") + e.what());
      }
    });
  });
}

ExrImage read_exr(const std::string& path) {
  return with_context(path, [&] {
    try {
      Imf::InputFile file(path.c_str());
      const Imath::Box2i window = file.header().dataWindow();
      ExrImage image;
      image.width = window.max.x - window.min.x + 1;
      image.height = window.max.y - window.min.y + 1;
      if (image.width <= 0 || image.height <= 0 || static_cast<long long>(image.width) * image.height > (1ll << 28))
        throw Error("data window of " + std::to_string(image.width) + " x " + std::to_string(image.height) + " pixels");
      const std::size_t pixels = static_cast<std::size_t>(image.width) * static_cast<std::size_t>(image.height);
      image.rgba.assign(4 * pixels, 0.0f);
      const bool has_z = file.header().channels().findChannel("Z") != nullptr;
      if (has_z) image.depth.assign(pixels, 0.0f);
      // the slices address pixel (x, y) of the data window at base + x * xs + y * ys
      const std::ptrdiff_t shift = static_cast<std::ptrdiff_t>(window.min.x) + static_cast<std::ptrdiff_t>(window.min.y) * image.width;
      Imf::FrameBuffer fb;
      for (int c = 0; c < 4; ++c)
        fb.insert(kRgba[c], float_slice(image.rgba.data() - 4 * shift + c, 4, image.width, c == 3 ? 1.0f : 0.0f));
      if (has_z) fb.insert("Z", float_slice(image.depth.data() - shift, 1, image.width, std::numeric_limits<float>::infinity()));
      file.setFrameBuffer(fb);
      file.readPixels(window.min.y, window.max.y);
      return image;
    } catch (const Error&) {
      throw;
    } catch (const std::exception& e) {
      throw Error(std::string("not a readable OpenEXR file: ") + e.what());
    }
  });
}

}  // namespace penumbra
