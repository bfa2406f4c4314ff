#include "penumbra/viewer/jpeg.h"

#include <cstdio>
#include <jpeglib.h>

#include <cstdlib>
#include <vector>

#include "penumbra/core/color.h"
#include "penumbra/core/error.h"

namespace penumbra {

std::string encode_jpeg(const Image& image, int quality) {
  jpeg_compress_struct info{};
  jpeg_error_mgr errors{};
  info.err = jpeg_std_error(&errors);
  errors.error_exit = [](j_common_ptr c) {  // libjpeg's default exits the process
    char message[JMSG_LENGTH_MAX];
    (*c->err->format_message)(c, message);
    throw Error(std::string("JPEG encoding failed: ") + message);
  };
  unsigned char* buffer = nullptr;
  unsigned long size = 0;
  std::string out;
  try {
    jpeg_create_compress(&info);
    jpeg_mem_dest(&info, &buffer, &size);
    info.image_width = static_cast<JDIMENSION>(image.width());
    info.image_height = static_cast<JDIMENSION>(image.height());
    info.input_components = 3;
    info.in_color_space = JCS_RGB;
    jpeg_set_defaults(&info);
    jpeg_set_quality(&info, quality, TRUE);
    jpeg_start_compress(&info, TRUE);
    std::vector<unsigned char> row(static_cast<std::size_t>(image.width()) * 3);
    for (int y = 0; y < image.height(); ++y) {
      for (int x = 0; x < image.width(); ++x)
        for (int c = 0; c < 3; ++c) row[static_cast<std::size_t>(x) * 3 + static_cast<std::size_t>(c)] = linear_to_srgb8(image.at(x, y)[c]);
      JSAMPROW r = row.data();
      jpeg_write_scanlines(&info, &r, 1);
    }
    jpeg_finish_compress(&info);
    out.assign(reinterpret_cast<const char*>(buffer), size);
  } catch (...) {
    jpeg_destroy_compress(&info);
    std::free(buffer);
    throw;
  }
  jpeg_destroy_compress(&info);
  std::free(buffer);
  return out;
}

}  // namespace penumbra
