// Pinhole perspective camera. Pixel (x, y) has y = 0 at the top of the image.
#pragma once

#include "penumbra/core/math.h"

namespace penumbra {

struct Camera {
  Vec3 eye{2, 1.5f, 2};
  Vec3 target{0, 0, 0};
  Vec3 up{0, 1, 0};
  float fov_deg = 35;  // vertical field of view
  int width = 512;
  int height = 512;

  // Ray through the image point (px, py) in pixel units (pixel centres at +0.5).
  Ray primary_ray(float px, float py) const {
    const Frame f = Frame::from_w(eye - target, up);  // w points backwards, as in a right-handed camera
    const float tan_half = std::tan(radians(fov_deg) * 0.5f);
    const float aspect = static_cast<float>(width) / static_cast<float>(height);
    const float sx = (2.0f * px / static_cast<float>(width) - 1.0f) * tan_half * aspect;
    const float sy = (1.0f - 2.0f * py / static_cast<float>(height)) * tan_half;
    return Ray{eye, normalize(f.u * sx + f.v * sy - f.w)};
  }

  // The camera turned by `angle` radians about the vertical axis (`up`) through the target.
  Camera orbited(float angle) const {
    Camera c = *this;
    const Vec3 axis = normalize(up);
    const Vec3 d = eye - target;
    const float cs = std::cos(angle), sn = std::sin(angle);
    // Rodrigues' rotation of d about axis
    c.eye = target + d * cs + cross(axis, d) * sn + axis * (dot(axis, d) * (1 - cs));
    return c;
  }
};

}  // namespace penumbra
