// A view the isosurface extraction runs from: the eye's camera, or the light's frustum of paper 002
// §4.3 (perspective for point and spot lights, with an image window that need not be centred on the
// line of sight: "a perspective projection that is not symmetric"; orthographic for directional
// lights). Maps world points to continuous pixel coordinates and pixels back to rays. Built from a
// Camera it reproduces PrimaryRays exactly, so extracted points land on the pixels the rest of the
// renderer uses.
#pragma once

#include "penumbra/core/math.h"
#include "penumbra/scene/camera.h"

namespace penumbra {

struct ViewProjection {
  Vec3 eye;                 // the eye or light position; for orthographic views a point on the plane behind the scene
  Frame frame;              // looks along -w
  bool orthographic = false;
  // The image window on the plane one unit in front of the eye (perspective: x/z and y/z of a point in
  // the frame) or on the view plane in world units (orthographic); pixel (0, 0) is at (left, top).
  float left = -1, right = 1, bottom = -1, top = 1;
  int width = 1, height = 1;

  static ViewProjection from_camera(const Camera& camera) {
    const PrimaryRays rays(camera);
    ViewProjection v;
    v.eye = camera.eye;
    v.frame = rays.frame;
    const float tan_half = std::tan(radians(camera.fov_deg) * 0.5f);
    const float aspect = static_cast<float>(camera.width) / static_cast<float>(camera.height);
    v.left = -tan_half * aspect;
    v.right = tan_half * aspect;
    v.bottom = -tan_half;
    v.top = tan_half;
    v.width = camera.width;
    v.height = camera.height;
    return v;
  }

  // Depth along the view direction (perspective: > 0 in front of the eye).
  float depth(const Vec3& p) const { return -dot(p - eye, frame.w); }
  // Continuous pixel coordinates of p; false when p is not in front of the eye (perspective).
  bool project(const Vec3& p, float& px, float& py) const {
    const Vec3 d = p - eye;
    float sx = dot(d, frame.u), sy = dot(d, frame.v);
    if (!orthographic) {
      const float z = -dot(d, frame.w);
      if (!(z > 0)) return false;
      sx /= z;
      sy /= z;
    }
    px = (sx - left) / (right - left) * static_cast<float>(width);
    py = (top - sy) / (top - bottom) * static_cast<float>(height);
    return true;
  }
  // The ray through the image point (px, py) (pixel units, pixel centres at +0.5).
  Ray ray(float px, float py) const {
    const float sx = left + (right - left) * px / static_cast<float>(width);
    const float sy = top - (top - bottom) * py / static_cast<float>(height);
    if (orthographic) return Ray{eye + frame.u * sx + frame.v * sy, -frame.w};
    return Ray{eye, normalize(frame.u * sx + frame.v * sy - frame.w)};
  }
  // What IsoPoint::distance holds for a point seen from this view: the distance from the eye
  // (perspective) or the depth behind the view plane (orthographic).
  float distance(const Vec3& p) const { return orthographic ? depth(p) : length(p - eye); }
  // World size of a pixel at distance `distance` (the larger of its two sides).
  float pixel_size(float distance) const {
    const float s = std::max((right - left) / static_cast<float>(width), (top - bottom) / static_cast<float>(height));
    return orthographic ? s : s * distance;
  }
};

}  // namespace penumbra
