// The interface of ambient-occlusion techniques (DESIGN.md): build() looks at the scene's absorbers once
// (per transfer function), ambient() answers, for a batch of points, which fraction of the ambient light
// of each colour reaches them. The ray caster multiplies its ambient term by it.
#pragma once

#include <cstddef>
#include <span>
#include <string_view>

#include "penumbra/core/color.h"
#include "penumbra/core/math.h"
#include "penumbra/shadows/shadow_medium.h"

namespace penumbra {

class AmbientTechnique {
public:
  virtual ~AmbientTechnique() = default;
  virtual void build(const ShadowMedium& medium) = 0;
  virtual void ambient(std::span<const Vec3> points, std::span<Rgb> out) const = 0;
  virtual std::size_t memory_bytes() const = 0;
  virtual std::string_view name() const = 0;

  Rgb ambient(const Vec3& p) const {
    Rgb out;
    ambient(std::span<const Vec3>(&p, 1), std::span<Rgb>(&out, 1));
    return out;
  }
};

}  // namespace penumbra
