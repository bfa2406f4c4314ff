// Lights: directional (parallel rays travelling along `direction`), point (at `position`), and spot
// (at `position`, aimed along `direction`, cone half-angle `angle_deg` with a smooth edge).
#pragma once

#include <string>

#include "penumbra/core/color.h"
#include "penumbra/core/math.h"

namespace penumbra {

enum class LightType { Directional, Point, Spot };

std::string to_string(LightType type);

struct Light {
  LightType type = LightType::Directional;
  Vec3 position{0, 0, 0};       // point and spot
  Vec3 direction{0, -1, 0};     // directional: travel direction; spot: axis (unit)
  Rgb color{1, 1, 1};
  float intensity = 1;
  float angle_deg = 30;         // spot: half-angle of the cone
  float softness = 0.2f;        // spot: fraction of the angle over which the edge fades

  // Unit vector from p towards the light and the distance to it (infinity for directional lights).
  void towards(const Vec3& p, Vec3& to_light, float& distance) const {
    if (type == LightType::Directional) {
      to_light = -direction;
      distance = kInfinity;
    } else {
      const Vec3 d = position - p;
      distance = length(d);
      to_light = distance > 0 ? d / distance : Vec3{0, 1, 0};
    }
  }
  // Radiance scale at p before shadowing: colour x intensity x spot cone falloff.
  Rgb emitted(const Vec3& to_light) const {
    Rgb e = color * intensity;
    if (type == LightType::Spot) {
      const float cos_angle = dot(-to_light, direction);
      const float outer = std::cos(radians(angle_deg));
      const float inner = std::cos(radians(angle_deg * (1 - softness)));
      const float t = inner > outer ? clamp((cos_angle - outer) / (inner - outer), 0, 1) : (cos_angle >= outer ? 1.f : 0.f);
      e *= t * t * (3 - 2 * t);
    }
    return e;
  }
  bool operator==(const Light&) const = default;
};

}  // namespace penumbra
