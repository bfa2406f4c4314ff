// JPEG encoding of frames (libjpeg-turbo through the libjpeg API), for the viewer's compressed frames.
#pragma once

#include <string>

#include "penumbra/core/image.h"

namespace penumbra {

// The image (linear RGB) as sRGB JPEG bytes at `quality` (1–100).
std::string encode_jpeg(const Image& image, int quality);

}  // namespace penumbra
