// Procedural volumes (procedural.h): analytic shapes sampled at voxel centres on [-0.5, 0.5]^3, the
// Marschner-Lobb signal (Marschner & Lobb, "An evaluation of reconstruction filters for volume
// rendering", 1994) and a "test spheres" volume in the spirit of Roettger's data set used by the CSSM
// paper (overlapping spheres of constant, distinct densities).
#include "penumbra/data/procedural.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <sstream>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/data/ct_body.h"

namespace penumbra {

namespace {

using nlohmann::json;


std::string join(const std::vector<std::string>& names) {
  std::string s;
  for (const std::string& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

// The parameters each shape accepts besides "name" and "size", with their defaults.
const std::map<std::string, std::map<std::string, double>>& shape_params() {
  static const std::map<std::string, std::map<std::string, double>> params{
      {"test-spheres", {{"seed", -1.0}}},
      {"slab", {{"thickness", 0.3}}},
      {"sphere", {{"radius", 0.35}}},
      {"hollow-sphere", {{"radius", 0.35}, {"thickness", 0.08}}},
      {"marschner-lobb", {{"alpha", 0.25}, {"fm", 6.0}}},
      {"ct-body", {{"dims", 0.0}, {"seed", 1.0}, {"noise", 60.0}}},
  };
  return params;
}

double number_param(const json& spec, const std::string& shape, const std::string& key, double fallback,
                    double min_value, bool min_inclusive) {
  if (!spec.contains(key)) return fallback;
  const json& v = spec[key];
  const std::string where = "procedural volume \"" + shape + "\": \"" + key + "\": " + v.dump();
  if (!v.is_number() || !std::isfinite(v.get<double>())) throw Error(where + " (expected a finite number)");
  const double d = v.get<double>();
  if (min_inclusive ? d < min_value : d <= min_value)
    throw Error(where + " (expected a number " + (min_inclusive ? ">= " : "> ") + num(min_value) + ")");
  return d;
}

struct Ball {
  double cx, cy, cz, radius, density;
};

// The fixed layout: a large faint sphere holding a nested denser one, a second sphere overlapping it
// with the densest one nested inside, and a dense sphere overlapping the large one from below. All
// stay at least 0.06 inside the box so the smoothed edges are not cut by the border.
std::vector<Ball> test_sphere_layout(std::int64_t seed) {
  std::vector<Ball> balls{{-0.12, -0.05, 0.00, 0.32, 0.2},
                          {0.20, 0.15, 0.10, 0.22, 0.4},
                          {-0.15, -0.10, 0.05, 0.14, 0.6},
                          {0.18, -0.25, -0.15, 0.15, 0.8},
                          {0.22, 0.17, 0.12, 0.08, 1.0}};
  if (seed >= 0) {
    // A seeded variant: centres jittered by up to +-0.04 and radii by +-10%, clamped back into the margin.
    const auto s = static_cast<std::uint64_t>(seed);
    for (std::size_t i = 0; i < balls.size(); ++i) {
      Ball& b = balls[i];
      b.radius *= 0.9 + 0.2 * uniform_float(s, i, 3);
      double* c[3] = {&b.cx, &b.cy, &b.cz};
      for (std::uint64_t a = 0; a < 3; ++a) {
        *c[a] += 0.08 * (uniform_float(s, i, a) - 0.5);
        const double limit = 0.44 - b.radius;
        *c[a] = std::clamp(*c[a], -limit, limit);
      }
    }
  }
  return balls;
}

// "ct-body" (ct_body.h): its own grid ("dims", not "size"), a seed and the noise level.
CtBodyParams ct_body_params(const json& spec) {
  CtBodyParams p;
  const std::string where = "procedural volume \"ct-body\": ";
  if (spec.contains("dims")) {
    const json& d = spec["dims"];
    bool ok = d.is_array() && d.size() == 3;
    for (std::size_t a = 0; ok && a < 3; ++a)
      ok = d[a].is_number_integer() && d[a].get<std::int64_t>() >= 8 && d[a].get<std::int64_t>() <= 2048;
    if (!ok) throw Error(where + "\"dims\": " + d.dump() + " (expected [x, y, z]: three integers in 8..2048)");
    for (std::size_t a = 0; a < 3; ++a) p.dims[a] = static_cast<int>(d[a].get<std::int64_t>());
  }
  if (spec.contains("seed")) {
    const json& s = spec["seed"];
    if (!s.is_number_integer() || s.get<std::int64_t>() < 0)
      throw Error(where + "\"seed\": " + s.dump() + " (expected an integer >= 0)");
    p.seed = static_cast<std::uint64_t>(s.get<std::int64_t>());
  }
  p.noise = number_param(spec, "ct-body", "noise", p.noise, 0.0, true);
  if (p.noise > 10000) throw Error(where + "\"noise\": " + num(p.noise) + " (expected at most 10000)");
  return p;
}

}  // namespace

std::vector<std::string> procedural_volume_names() {
  return {"test-spheres", "slab", "sphere", "hollow-sphere", "marschner-lobb", "ct-body"};
}

Volume make_procedural_volume(const nlohmann::json& spec) {
  if (!spec.is_object()) throw Error("procedural volume: " + spec.dump() + " (expected an object)");
  if (!spec.contains("name") || !spec["name"].is_string())
    throw Error("procedural volume: \"name\" " + (spec.contains("name") ? spec["name"].dump() + " " : std::string("missing ")) +
                "(expected one of: " + join(procedural_volume_names()) + ")");
  const std::string name = spec["name"].get<std::string>();
  const auto shape = shape_params().find(name);
  if (shape == shape_params().end())
    throw Error("procedural volume: \"name\": \"" + name + "\" is not known (expected one of: " +
                join(procedural_volume_names()) + ")");
  const bool ct_body = name == "ct-body";  // a grid of its own ("dims" over a box in mm), no "size"
  for (const auto& [key, val] : spec.items()) {
    if (key == "name" || (key == "size" && !ct_body) || shape->second.count(key)) continue;
    if (key == "size")
      throw Error("procedural volume \"ct-body\": \"size\" does not apply (its grid is \"dims\": [x, y, z], "
                  "default [512, 512, 1734], over a 500 x 500 x 1734 mm box)");
    std::vector<std::string> allowed{"name"};
    if (!ct_body) allowed.push_back("size");
    for (const auto& [k, d] : shape->second) allowed.push_back(k);
    throw Error("procedural volume \"" + name + "\": unknown key \"" + key + "\" (expected " + join(allowed) + ")");
  }

  if (ct_body) return make_ct_body_volume(ct_body_params(spec));

  int size = 64;
  if (spec.contains("size")) {
    const json& s = spec["size"];
    if (!s.is_number_integer() || s.get<std::int64_t>() < 2 || s.get<std::int64_t>() > 1024)
      throw Error("procedural volume \"" + name + "\": \"size\": " + s.dump() + " (expected an integer in 2..1024)");
    size = static_cast<int>(s.get<std::int64_t>());
  }
  const double h = 1.0 / (size - 1);
  Volume vol(ScalarType::Float32, {size, size, size}, Vec3(static_cast<float>(h), static_cast<float>(h), static_cast<float>(h)),
             Vec3(-0.5f, -0.5f, -0.5f));

  // The density at a voxel centre, computed in double so hard-edged shapes classify voxels on the
  // boundary exactly as the analytic test |y| <= t/2 or r <= R says.
  std::function<double(double, double, double)> density;
  if (name == "slab") {
    const double half = 0.5 * number_param(spec, name, "thickness", 0.3, 0.0, false);
    density = [half](double, double y, double) { return std::abs(y) <= half + 1e-12 ? 1.0 : 0.0; };
  } else if (name == "sphere") {
    const double r = number_param(spec, name, "radius", 0.35, 0.0, false);
    density = [r](double x, double y, double z) { return x * x + y * y + z * z <= r * r + 1e-12 ? 1.0 : 0.0; };
  } else if (name == "hollow-sphere") {
    const double r = number_param(spec, name, "radius", 0.35, 0.0, false);
    const double t = number_param(spec, name, "thickness", 0.08, 0.0, false);
    if (t > r)
      throw Error("procedural volume \"hollow-sphere\": \"thickness\": " + num(t) + " (expected at most the radius " + num(r) + ")");
    density = [r, t](double x, double y, double z) {
      const double d = std::sqrt(x * x + y * y + z * z);
      return d >= r - t - 1e-12 && d <= r + 1e-12 ? 1.0 : 0.0;
    };
  } else if (name == "marschner-lobb") {
    const double alpha = number_param(spec, name, "alpha", 0.25, 0.0, true);
    const double fm = number_param(spec, name, "fm", 6.0, 0.0, true);
    density = [alpha, fm](double px, double py, double pz) {
      const double pi = 3.14159265358979323846;
      const double x = 2 * px, y = 2 * py, z = 2 * pz;  // the signal is defined on [-1, 1]^3
      const double rho_r = std::cos(2 * pi * fm * std::cos(pi * std::sqrt(x * x + y * y) / 2));
      return (1 - std::sin(pi * z / 2) + alpha * (1 + rho_r)) / (2 * (1 + alpha));
    };
  } else {  // test-spheres
    std::int64_t seed = -1;
    if (spec.contains("seed")) {
      const json& s = spec["seed"];
      if (!s.is_number_integer() || s.get<std::int64_t>() < 0)
        throw Error("procedural volume \"test-spheres\": \"seed\": " + s.dump() + " (expected an integer >= 0)");
      seed = s.get<std::int64_t>();
    }
    const std::vector<Ball> balls = test_sphere_layout(seed);
    // Each edge is a smoothstep over 1.5 voxels centred on the radius (so the ball keeps its volume),
    // giving well-defined gradients; overlaps take the largest density, keeping plateaus exact.
    const double width = 1.5 * h;
    density = [balls, width](double x, double y, double z) {
      double d = 0;
      for (const Ball& b : balls) {
        const double r = std::sqrt((x - b.cx) * (x - b.cx) + (y - b.cy) * (y - b.cy) + (z - b.cz) * (z - b.cz));
        const double s = std::clamp((b.radius - r) / width + 0.5, 0.0, 1.0);
        d = std::max(d, b.density * s * s * (3 - 2 * s));
      }
      return d;
    };
  }

  // Slices in parallel; each voxel is written once, so the result does not depend on the thread count.
  float* out = vol.data_as<float>();
  parallel_for(static_cast<std::size_t>(size), [&](std::size_t k0, std::size_t k1) {
    for (int k = static_cast<int>(k0); k < static_cast<int>(k1); ++k)
      for (int j = 0; j < size; ++j)
        for (int i = 0; i < size; ++i)
          out[vol.index(i, j, k)] = static_cast<float>(density(-0.5 + i * h, -0.5 + j * h, -0.5 + k * h));
  });
  vol.recompute_range();
  return vol;
}

}  // namespace penumbra
