// OpenEXR images (`render -o out.exr`): linear float RGBA with premultiplied alpha (EXR's convention:
// the picture composites over any background), and the depth channel Z when asked. Written through
// the OpenEXR library (FLOAT channels, ZIP compression) to a temporary file renamed into place.
#pragma once

#include <string>
#include <vector>

namespace penumbra {

struct ExrImage {
  int width = 0, height = 0;
  std::vector<float> rgba;   // 4 floats a pixel, rows top to bottom
  std::vector<float> depth;  // 1 float a pixel (distance along the primary ray, +infinity: nothing); empty: no Z
};

void write_exr(const std::string& path, const ExrImage& image);
// Reads R, G, B, A (A = 1 where the file has none) and Z (left empty where the file has none).
ExrImage read_exr(const std::string& path);

}  // namespace penumbra
