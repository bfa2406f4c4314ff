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

  // Ray through the image point (px, py) in pixel units (pixel centres at +0.5). Loops over pixels use
  // PrimaryRays, which sets the camera frame up once.
  Ray primary_ray(float px, float py) const;

  bool operator==(const Camera&) const = default;

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

// The camera's primary rays with its frame and image-plane scales computed once, for loops over pixels;
// also maps image-plane coordinates (x/z, y/z in the camera frame) to pixel coordinates and back.
class PrimaryRays {
public:
  explicit PrimaryRays(const Camera& c)
      : frame(Frame::from_w(c.eye - c.target, c.up)), eye(c.eye), width(c.width), height(c.height) {
    const float tan_half = std::tan(radians(c.fov_deg) * 0.5f);
    const float aspect = static_cast<float>(c.width) / static_cast<float>(c.height);
    sx_scale_ = 2.0f * tan_half * aspect / static_cast<float>(c.width);
    sy_scale_ = 2.0f * tan_half / static_cast<float>(c.height);
  }
  // Unit direction through the image point (px, py) in pixel units; pixel (x, y) is at (x + ½, y + ½).
  Vec3 direction(float px, float py) const {
    const float sx = (px - 0.5f * static_cast<float>(width)) * sx_scale_;
    const float sy = (0.5f * static_cast<float>(height) - py) * sy_scale_;
    return normalize(frame.u * sx + frame.v * sy - frame.w);
  }
  Vec3 direction(int x, int y) const { return direction(static_cast<float>(x) + 0.5f, static_cast<float>(y) + 0.5f); }
  Ray ray(int x, int y) const { return Ray{eye, direction(x, y)}; }
  // Pixel coordinates of the image-plane point (sx, sy).
  float pixel_x(float sx) const { return sx / sx_scale_ + 0.5f * static_cast<float>(width); }
  float pixel_y(float sy) const { return 0.5f * static_cast<float>(height) - sy / sy_scale_; }

  Frame frame;  // w points backwards, as in a right-handed camera
  Vec3 eye;
  int width, height;

private:
  float sx_scale_, sy_scale_;  // image-plane units per pixel
};

inline Ray Camera::primary_ray(float px, float py) const { return Ray{eye, PrimaryRays(*this).direction(px, py)}; }

}  // namespace penumbra
