// Shared helpers of the isosurface tests: a volume sampled from a field on [-1, 1]^3, and a camera
// looking at the origin.
#pragma once

#include <functional>

#include "penumbra/data/volume.h"
#include "penumbra/scene/camera.h"

namespace penumbra::test {

// n^3 voxels on [-1, 1]^3 holding f(p), in `type` (values converted as they are stored).
inline Volume field_volume(int n, const std::function<float(const Vec3&)>& f, ScalarType type = ScalarType::Float32) {
  const float s = 2.0f / static_cast<float>(n - 1);
  Volume v(type, {n, n, n}, {s, s, s}, {-1, -1, -1});
  for (int k = 0; k < n; ++k)
    for (int j = 0; j < n; ++j)
      for (int i = 0; i < n; ++i)
        v.set_value(v.index(i, j, k), f({-1 + static_cast<float>(i) * s, -1 + static_cast<float>(j) * s,
                                          -1 + static_cast<float>(k) * s}));
  v.recompute_range();
  return v;
}

// A size x size camera at `eye` looking at the origin with a 40 degree field of view.
inline Camera camera_at(int size, const Vec3& eye) {
  Camera c;
  c.eye = eye;
  c.target = {0, 0, 0};
  c.fov_deg = 40;
  c.width = c.height = size;
  return c;
}

}  // namespace penumbra::test
