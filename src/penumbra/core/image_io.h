// Image files: 8-bit sRGB PNG, or linear float PFM, chosen by the file extension (OpenEXR, with alpha
// and depth, is exr_io.h; read_image also reads an .exr's colour).
// Writes go to a temporary file that is renamed into place, so a failure never leaves a partial image.
#pragma once

#include <string>

#include "penumbra/core/image.h"

namespace penumbra {

void write_image(const std::string& path, const Image& image);  // .png or .pfm
std::string encode_png(const Image& image);                     // the bytes of the .png write_image writes
Image read_image(const std::string& path);                      // .png (8/16-bit, gray/RGB/A), .pfm or .exr

}  // namespace penumbra
