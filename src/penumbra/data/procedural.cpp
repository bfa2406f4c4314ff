// Procedural volumes (procedural.h): analytic shapes sampled at voxel centres on [-0.5, 0.5]^3, the
// Marschner-Lobb signal (Marschner & Lobb, "An evaluation of reconstruction filters for volume
// rendering", 1994) and a "test spheres" volume in the spirit of Roettger's data set used by the CSSM
// paper (overlapping spheres of constant, distinct densities), and "molecular-density", a Gaussian splat
// of a molecule's atoms read with the particle loaders.
#include "penumbra/data/procedural.h"

#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <functional>
#include <map>
#include <numbers>
#include <sstream>
#include <filesystem>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/data/ct_body.h"
#include "penumbra/data/elements.h"
#include "penumbra/data/io/particle_io.h"

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
      {"sphere", {{"radius", 0.35}, {"frames", 0.0}, {"frame", 0.0}, {"orbit", 0.25}}},
      {"hollow-sphere", {{"radius", 0.35}, {"thickness", 0.08}}},
      {"marschner-lobb", {{"alpha", 0.25}, {"fm", 6.0}}},
      {"ct-body", {{"dims", 0.0}, {"seed", 1.0}, {"noise", 60.0}}},
      // padding's default is 3 sigma; file and weight are strings (the numbers are unused).
      {"molecular-density", {{"file", 0.0}, {"spacing", 1.5}, {"sigma", 1.5}, {"padding", 0.0}, {"weight", 0.0}}},
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

}  // namespace

// "ct-body" (ct_body.h): its own grid ("dims", not "size"), a seed and the noise level.
CtBodyParams ct_body_params(const json& spec, int max_dim) {
  CtBodyParams p;
  const std::string where = "procedural volume \"ct-body\": ";
  for (const auto& [key, value] : spec.items())
    if (key != "name" && key != "dims" && key != "seed" && key != "noise")
      throw Error(where + "unknown key \"" + key + "\" (expected name, dims, seed, noise)");
  if (spec.contains("dims")) {
    const json& d = spec["dims"];
    bool ok = d.is_array() && d.size() == 3;
    for (std::size_t a = 0; ok && a < 3; ++a)
      ok = d[a].is_number_integer() && d[a].get<std::int64_t>() >= 8 && d[a].get<std::int64_t>() <= max_dim;
    if (!ok) throw Error(where + "\"dims\": " + d.dump() + " (expected [x, y, z]: three integers in 8.." + std::to_string(max_dim) + ")");
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

namespace {

// ------------------------------------------------------------------------------- molecular-density

// The particle loaders keep no element per atom, but with their default options (colour by element,
// radius_scale 1) an atom's sphere carries exactly element_vdw_radius(Z) and pack_rgba8(element_color(Z)),
// and that pair differs for every Z of the table (tests/test_molecular_density.cpp checks it): the element
// is read back from it. kUnknownElement for a pair that is not in the table.
int element_of_atom(const Sphere& s, std::uint32_t color) {
  static const std::map<std::pair<float, std::uint32_t>, int> table = [] {
    std::map<std::pair<float, std::uint32_t>, int> t;
    for (int z = kMaxElement; z >= kUnknownElement; --z)  // on a collision the lower Z would win
      t[{element_vdw_radius(z), pack_rgba8(element_color(z))}] = z;
    return t;
  }();
  const auto it = table.find({s.radius, color});
  return it == table.end() ? kUnknownElement : it->second;
}

// "molecular-density": rho(x) = sum over atoms of w_a exp(-|x - c_a|^2 / (2 sigma^2)), each atom splatted
// only within 3 sigma of its centre, on a grid over the atoms' box plus padding whose world coordinates
// are the file's (Å).
Volume make_molecular_density(const json& spec, const std::string& base_dir) {
  const std::string shape = "molecular-density";
  const std::string where = "procedural volume \"" + shape + "\": ";
  if (!spec.contains("file") || !spec["file"].is_string() || spec["file"].get<std::string>().empty())
    throw Error(where + "\"file\" " + (spec.contains("file") ? spec["file"].dump() + " " : std::string("missing ")) +
                "(expected the path of a molecule file: .pdb, .cif, .gro, .xyz, optionally .gz)");
  std::string file = spec["file"].get<std::string>();
  if (!base_dir.empty() && std::filesystem::path(file).is_relative()) file = (std::filesystem::path(base_dir) / file).string();
  const double spacing = number_param(spec, shape, "spacing", 1.5, 0.0, false);
  const double sigma = number_param(spec, shape, "sigma", 1.5, 0.0, false);
  const double padding = number_param(spec, shape, "padding", 3 * sigma, 0.0, true);
  bool uniform = false;
  if (spec.contains("weight")) {
    const json& w = spec["weight"];
    if (!w.is_string() || (w.get<std::string>() != "atomic_number" && w.get<std::string>() != "uniform"))
      throw Error(where + "\"weight\": " + w.dump() + " (expected \"atomic_number\" or \"uniform\")");
    uniform = w.get<std::string>() == "uniform";
  }

  // The deposited coordinates (no biological assembly), hydrogens kept when the file has them.
  const ParticleSet atoms = load_particles(file, ParticleLoadOptions{});
  const std::size_t n_atoms = atoms.size();
  std::vector<float> weight(n_atoms, 1.0f);
  if (!uniform)
    for (std::size_t a = 0; a < n_atoms; ++a) {
      const int z = element_of_atom(atoms.spheres[a], atoms.colors[a]);
      weight[a] = static_cast<float>(z == kUnknownElement ? 6 : z);  // unknown: as carbon (as it is drawn)
    }

  double lo[3] = {kInfinity, kInfinity, kInfinity}, hi[3] = {-kInfinity, -kInfinity, -kInfinity};
  for (const Sphere& s : atoms.spheres)
    for (int a = 0; a < 3; ++a) {
      lo[a] = std::min(lo[a], static_cast<double>(s.center[a]));
      hi[a] = std::max(hi[a], static_cast<double>(s.center[a]));
    }
  std::array<int, 3> dims{};
  double n_voxels[3];
  for (int a = 0; a < 3; ++a) n_voxels[a] = std::max(2.0, std::ceil((hi[a] - lo[a] + 2 * padding) / spacing) + 1);
  if (!(n_voxels[0] <= 1024 && n_voxels[1] <= 1024 && n_voxels[2] <= 1024))
    throw Error(where + "\"spacing\": " + num(spacing) + " gives a grid of " + num(n_voxels[0]) + " x " + num(n_voxels[1]) +
                " x " + num(n_voxels[2]) + " voxels over the atoms' box (" + num(hi[0] - lo[0]) + " x " + num(hi[1] - lo[1]) +
                " x " + num(hi[2] - lo[2]) + " Å) plus \"padding\" " + num(padding) +
                " Å on each side (expected at most 1024 per dimension: a larger \"spacing\" or a smaller \"padding\")");
  for (int a = 0; a < 3; ++a) dims[a] = static_cast<int>(n_voxels[a]);
  const float h = static_cast<float>(spacing);
  Volume vol(ScalarType::Float32, dims, Vec3(h, h, h),
             Vec3(static_cast<float>(lo[0] - padding), static_cast<float>(lo[1] - padding), static_cast<float>(lo[2] - padding)));

  // Voxel (i, j, k) lies at origin + (i, j, k) * spacing, in the float values the volume stores.
  const double hd = vol.spacing().x;
  const double origin[3] = {vol.origin().x, vol.origin().y, vol.origin().z};
  const double cutoff = 3 * sigma, cutoff2 = cutoff * cutoff, inv_2s2 = 1 / (2 * sigma * sigma);
  // The voxel index range of each atom's cutoff box (empty when lo > hi).
  struct Range {
    int lo[3], hi[3];
  };
  std::vector<Range> range(n_atoms);
  parallel_for(n_atoms, [&](std::size_t b, std::size_t e) {
    for (std::size_t a = b; a < e; ++a)
      for (int d = 0; d < 3; ++d) {
        const double c = (atoms.spheres[a].center[d] - origin[d]) / hd, r = cutoff / hd;
        range[a].lo[d] = static_cast<int>(std::max(0.0, std::ceil(c - r)));
        range[a].hi[d] = static_cast<int>(std::min(dims[d] - 1.0, std::floor(c + r)));
      }
  }, 4096);

  // Slabs of kSlab z-slices, fixed by position: each slab lists the atoms whose cutoff box reaches it, in
  // file order, and one task writes all of a slab's voxels, adding the atoms in that order. Every voxel
  // therefore sums the same terms in the same order for any thread count: the bytes do not depend on it.
  constexpr int kSlab = 4;
  const int n_slabs = (dims[2] + kSlab - 1) / kSlab;
  std::vector<std::size_t> start(static_cast<std::size_t>(n_slabs) + 1, 0);
  for (const Range& r : range)
    if (r.lo[0] <= r.hi[0] && r.lo[1] <= r.hi[1] && r.lo[2] <= r.hi[2])
      for (int s = r.lo[2] / kSlab; s <= r.hi[2] / kSlab; ++s) ++start[static_cast<std::size_t>(s) + 1];
  for (int s = 0; s < n_slabs; ++s) start[s + 1] += start[s];
  std::vector<std::uint32_t> list(start.back());
  {
    std::vector<std::size_t> fill(start.begin(), start.end() - 1);
    for (std::size_t a = 0; a < n_atoms; ++a) {
      const Range& r = range[a];
      if (r.lo[0] <= r.hi[0] && r.lo[1] <= r.hi[1] && r.lo[2] <= r.hi[2])
        for (int s = r.lo[2] / kSlab; s <= r.hi[2] / kSlab; ++s) list[fill[s]++] = static_cast<std::uint32_t>(a);
    }
  }

  float* out = vol.data_as<float>();
  parallel_for(static_cast<std::size_t>(n_slabs), [&](std::size_t s0, std::size_t s1) {
    std::vector<double> dx2, gx;  // per voxel column of the atom's box: squared distance, Gaussian factor
    for (std::size_t s = s0; s < s1; ++s) {
      const int k_begin = static_cast<int>(s) * kSlab, k_end = std::min(dims[2], k_begin + kSlab);
      for (std::size_t l = start[s]; l < start[s + 1]; ++l) {
        const std::uint32_t a = list[l];
        const Range& r = range[a];
        const Vec3 c = atoms.spheres[a].center;
        const double w = weight[a];
        dx2.resize(static_cast<std::size_t>(r.hi[0] - r.lo[0] + 1));
        gx.resize(dx2.size());
        for (int i = r.lo[0]; i <= r.hi[0]; ++i) {
          const double d = origin[0] + i * hd - c.x;
          dx2[static_cast<std::size_t>(i - r.lo[0])] = d * d;
          gx[static_cast<std::size_t>(i - r.lo[0])] = std::exp(-d * d * inv_2s2);
        }
        for (int k = std::max(r.lo[2], k_begin); k <= std::min(r.hi[2], k_end - 1); ++k) {
          const double dz = origin[2] + k * hd - c.z;
          if (dz * dz > cutoff2) continue;
          const double wz = w * std::exp(-dz * dz * inv_2s2);
          for (int j = r.lo[1]; j <= r.hi[1]; ++j) {
            const double dy = origin[1] + j * hd - c.y, dyz2 = dy * dy + dz * dz;
            if (dyz2 > cutoff2) continue;
            const double wyz = wz * std::exp(-dy * dy * inv_2s2);
            float* row = out + vol.index(0, j, k);
            for (int i = r.lo[0]; i <= r.hi[0]; ++i) {
              const std::size_t q = static_cast<std::size_t>(i - r.lo[0]);
              if (dx2[q] + dyz2 <= cutoff2) row[i] += static_cast<float>(wyz * gx[q]);
            }
          }
        }
      }
    }
  });
  vol.recompute_range();
  return vol;
}

}  // namespace

std::vector<std::string> procedural_volume_names() {
  return {"test-spheres", "slab", "sphere", "hollow-sphere", "marschner-lobb", "ct-body", "molecular-density"};
}

Volume make_procedural_volume(const nlohmann::json& spec, const std::string& base_dir) {
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
  const bool molecule = name == "molecular-density";  // its grid follows from the atoms and "spacing"
  for (const auto& [key, val] : spec.items()) {
    if (key == "name" || (key == "size" && !ct_body && !molecule) || shape->second.count(key)) continue;
    if (key == "size" && ct_body)
      throw Error("procedural volume \"ct-body\": \"size\" does not apply (its grid is \"dims\": [x, y, z], "
                  "default [512, 512, 1734], over a 500 x 500 x 1734 mm box)");
    if (key == "size")
      throw Error("procedural volume \"molecular-density\": \"size\" does not apply (its grid covers the atoms' box "
                  "plus \"padding\" with voxels of edge \"spacing\")");
    std::vector<std::string> allowed{"name"};
    if (!ct_body && !molecule) allowed.push_back("size");
    for (const auto& [k, d] : shape->second) allowed.push_back(k);
    throw Error("procedural volume \"" + name + "\": unknown key \"" + key + "\" (expected " + join(allowed) + ")");
  }

  if (ct_body) return make_ct_body_volume(ct_body_params(spec));
  if (molecule) return make_molecular_density(spec, base_dir);

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
    // a time series when "frames" is given: the ball orbits the y axis, one turn over the frames
    const double frames = number_param(spec, name, "frames", 0.0, 0.0, true);
    const double frame = number_param(spec, name, "frame", 0.0, 0.0, true);
    const double orbit = frames > 0 ? number_param(spec, name, "orbit", 0.25, 0.0, true) : 0.0;
    const double angle = frames > 0 ? 2 * std::numbers::pi * frame / frames : 0.0;
    const double cx = orbit * std::cos(angle), cz = orbit * std::sin(angle);
    density = [r, cx, cz](double x, double y, double z) {
      return (x - cx) * (x - cx) + y * y + (z - cz) * (z - cz) <= r * r + 1e-12 ? 1.0 : 0.0;
    };
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
