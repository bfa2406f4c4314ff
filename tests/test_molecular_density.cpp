// Tests for the "molecular-density" procedural volume (procedural.h): a Gaussian splat of a molecule's
// atoms. Against a brute-force sum over all atoms in double precision (with and without the 3 sigma
// cutoff), the closed-form Gaussian of a single atom, the grid's world coordinates (the peak lies at
// the atom), atomic-number weights read back from the particle loader, the same bytes for 1 and 2
// threads, relative paths through the scene file, the validation of the spec, and GroEL (1AON) when the
// shared data is there.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/rng.h"
#include "penumbra/data/elements.h"
#include "penumbra/data/io/particle_io.h"
#include "penumbra/data/procedural.h"
#include "penumbra/scene_io/scene_file.h"
#include "test_volume_io_util.h"

using namespace penumbra;
using nlohmann::json;
using penumbra::test::TempDir;
using penumbra::test::write_file;

namespace {

struct Atom {
  std::string symbol;
  double x, y, z;
  int z_number;
};

// An XYZ file of the atoms (coordinates with 4 decimals, which float holds exactly enough).
std::string write_xyz(const TempDir& dir, const std::string& name, const std::vector<Atom>& atoms) {
  std::string text = std::to_string(atoms.size()) + "\ntest molecule\n";
  char line[128];
  for (const Atom& a : atoms) {
    std::snprintf(line, sizeof line, "%s %.4f %.4f %.4f\n", a.symbol.c_str(), a.x, a.y, a.z);
    text += line;
  }
  const std::string path = dir.file(name);
  write_file(path, text);
  return path;
}

// `n` atoms of common biological elements at random positions in a box of edge `edge` Å.
std::vector<Atom> random_atoms(std::size_t n, double edge, std::uint64_t seed) {
  const std::vector<std::pair<std::string, int>> kinds{{"C", 6}, {"N", 7}, {"O", 8}, {"S", 16}, {"H", 1}, {"P", 15}, {"Fe", 26}};
  std::vector<Atom> atoms;
  for (std::size_t i = 0; i < n; ++i) {
    const auto& k = kinds[static_cast<std::size_t>(uniform_float(seed, i, 3) * 6.999)];
    atoms.push_back({k.first, edge * (uniform_float(seed, i, 0) - 0.5) + 3.0, edge * (uniform_float(seed, i, 1) - 0.5) - 7.0,
                     edge * 0.7 * (uniform_float(seed, i, 2) - 0.5), k.second});
  }
  return atoms;
}

json spec_for(const std::string& file, double spacing, double sigma) {
  return json{{"name", "molecular-density"}, {"file", file}, {"spacing", spacing}, {"sigma", sigma}};
}

// World position of voxel (i, j, k) in double, from the float origin and spacing the volume stores.
std::array<double, 3> voxel_position(const Volume& v, int i, int j, int k) {
  return {static_cast<double>(v.origin().x) + i * static_cast<double>(v.spacing().x),
          static_cast<double>(v.origin().y) + j * static_cast<double>(v.spacing().y),
          static_cast<double>(v.origin().z) + k * static_cast<double>(v.spacing().z)};
}

std::string error_of(const json& spec) {
  try {
    make_procedural_volume(spec);
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "expected a penumbra::Error for " << spec.dump();
  return "";
}

}  // namespace

// The loaders keep no element per atom; the volume reads it back from the sphere's (radius, colour)
// under the loader's default options. That works only if the pair differs for every element.
TEST(MolecularDensity, RadiusAndColourIdentifyEveryElement) {
  std::map<std::pair<float, std::uint32_t>, int> seen;
  for (int z = kUnknownElement; z <= kMaxElement; ++z) {
    const auto [it, inserted] = seen.emplace(std::make_pair(element_vdw_radius(z), pack_rgba8(element_color(z))), z);
    EXPECT_TRUE(inserted) << element_symbol(z) << " has the radius and colour of " << element_symbol(it->second);
  }
}

TEST(MolecularDensity, SingleAtomIsTheClosedFormGaussian) {
  TempDir dir;
  const double cx = 1.3, cy = -2.1, cz = 0.7, sigma = 1.2, spacing = 0.5, padding = 4.0;
  const std::string file = write_xyz(dir, "one.xyz", {{"N", cx, cy, cz, 7}});
  json spec = spec_for(file, spacing, sigma);
  spec["padding"] = padding;
  const Volume v = make_procedural_volume(spec);
  EXPECT_EQ(v.type(), ScalarType::Float32);
  EXPECT_EQ(v.dims(), (std::array<int, 3>{17, 17, 17}));  // 2 * 4 / 0.5 + 1
  EXPECT_FLOAT_EQ(v.origin().x, static_cast<float>(cx) - 4.0f);
  EXPECT_FLOAT_EQ(v.origin().y, static_cast<float>(cy) - 4.0f);
  EXPECT_FLOAT_EQ(v.origin().z, static_cast<float>(cz) - 4.0f);
  EXPECT_FLOAT_EQ(v.spacing().x, 0.5f);
  const double c[3] = {static_cast<float>(cx), static_cast<float>(cy), static_cast<float>(cz)};  // as the loader stores them
  int inside = 0;
  for (int k = 0; k < 17; ++k)
    for (int j = 0; j < 17; ++j)
      for (int i = 0; i < 17; ++i) {
        const auto p = voxel_position(v, i, j, k);
        const double d2 = (p[0] - c[0]) * (p[0] - c[0]) + (p[1] - c[1]) * (p[1] - c[1]) + (p[2] - c[2]) * (p[2] - c[2]);
        const double expected = d2 <= 9 * sigma * sigma ? 7 * std::exp(-d2 / (2 * sigma * sigma)) : 0.0;
        inside += d2 <= 9 * sigma * sigma ? 1 : 0;
        ASSERT_NEAR(v.value(i, j, k), expected, 1e-6 * 7) << i << " " << j << " " << k;
      }
  EXPECT_GT(inside, 1000);  // the ball of radius 3.6 Å holds about 4/3 pi 7.2^3 = 1563 voxels
  EXPECT_NEAR(v.max_value(), 7.0f, 1e-5f);  // the atom sits on the centre voxel
  EXPECT_EQ(v.min_value(), 0.0f);           // the corners lie beyond the cutoff
}

TEST(MolecularDensity, WorldCoordinatesLineUpWithTheAtoms) {
  TempDir dir;
  // Off the voxel lattice; padding 3.3 keeps the first atom 0.3 voxel from a voxel centre on each axis.
  const std::vector<Atom> atoms{{"C", -4.0, 2.0, 5.0, 6}, {"O", 9.37, 11.2, -3.9, 8}, {"Fe", 2.61, -6.45, 12.08, 26}};
  const std::string file = write_xyz(dir, "three.xyz", atoms);
  json spec = spec_for(file, 1.0, 0.9);
  spec["padding"] = 3.3;
  const Volume v = make_procedural_volume(spec);
  const ParticleSet particles = load_particles(file, {});  // the same file as spheres
  ASSERT_EQ(particles.size(), 3u);
  for (std::size_t a = 0; a < atoms.size(); ++a) {
    const Vec3 c = particles.spheres[a].center;
    // The largest voxel within two voxels of the atom is the one nearest it, and it lies within half a
    // voxel of the atom in world coordinates; the volume's own to_voxel agrees.
    const Vec3 g = v.to_voxel(c);
    int best[3] = {-1, -1, -1};
    float best_value = -1;
    for (int k = static_cast<int>(g.z) - 2; k <= static_cast<int>(g.z) + 2; ++k)
      for (int j = static_cast<int>(g.y) - 2; j <= static_cast<int>(g.y) + 2; ++j)
        for (int i = static_cast<int>(g.x) - 2; i <= static_cast<int>(g.x) + 2; ++i)
          if (v.value(i, j, k) > best_value) {
            best_value = v.value(i, j, k);
            best[0] = i, best[1] = j, best[2] = k;
          }
    const auto p = voxel_position(v, best[0], best[1], best[2]);
    for (int d = 0; d < 3; ++d) EXPECT_LE(std::abs(p[static_cast<std::size_t>(d)] - c[d]), 0.5 + 1e-5) << atoms[a].symbol << " axis " << d;
    EXPECT_EQ(best[0], static_cast<int>(std::lround(g.x))) << atoms[a].symbol;
    EXPECT_EQ(best[1], static_cast<int>(std::lround(g.y))) << atoms[a].symbol;
    EXPECT_EQ(best[2], static_cast<int>(std::lround(g.z))) << atoms[a].symbol;
    EXPECT_GT(best_value, 0.8f * static_cast<float>(atoms[a].z_number));  // at most 0.87 voxel away: exp(-0.75/1.62) = 0.63..1
    EXPECT_LE(best_value, static_cast<float>(atoms[a].z_number) * (1 + 1e-6f));  // the atoms are far apart
  }
  // The particles' centres lie inside the volume's box, padding away from its faces.
  const Box3 b = v.bounds();
  EXPECT_NEAR(b.lo.x, -4.0f - 3.3f, 1e-5f);
  EXPECT_NEAR(b.lo.y, -6.45f - 3.3f, 1e-5f);
  EXPECT_NEAR(b.lo.z, -3.9f - 3.3f, 1e-5f);
  EXPECT_GE(b.hi.x, 9.37f + 3.3f - 1e-5f);
  EXPECT_GE(b.hi.y, 11.2f + 3.3f - 1e-5f);
  EXPECT_GE(b.hi.z, 12.08f + 3.3f - 1e-5f);
}

TEST(MolecularDensity, AtomicNumbersAndUniformWeights) {
  TempDir dir;
  // Far apart (30 Å with sigma 1): each atom's voxel holds its weight alone. "Xx" is not an element.
  std::vector<Atom> atoms;
  const std::vector<std::pair<std::string, int>> kinds{{"H", 1}, {"C", 6}, {"N", 7}, {"O", 8}, {"S", 16},
                                                       {"Zn", 30}, {"U", 92}, {"Xx", 6}};
  for (std::size_t i = 0; i < kinds.size(); ++i) atoms.push_back({kinds[i].first, 30.0 * static_cast<double>(i), 0, 0, kinds[i].second});
  const std::string file = write_xyz(dir, "elements.xyz", atoms);
  json spec = spec_for(file, 1.0, 1.0);
  const Volume zw = make_procedural_volume(spec);
  spec["weight"] = "uniform";
  const Volume uw = make_procedural_volume(spec);
  spec["weight"] = "atomic_number";
  const Volume explicit_zw = make_procedural_volume(spec);
  for (const Atom& a : atoms) {
    const Vec3 g = zw.to_voxel(Vec3(static_cast<float>(a.x), 0, 0));
    const int i = static_cast<int>(std::lround(g.x)), j = static_cast<int>(std::lround(g.y)), k = static_cast<int>(std::lround(g.z));
    EXPECT_FLOAT_EQ(zw.value(i, j, k), static_cast<float>(a.z_number)) << a.symbol;
    EXPECT_FLOAT_EQ(uw.value(i, j, k), 1.0f) << a.symbol;
  }
  EXPECT_EQ(std::memcmp(zw.data(), explicit_zw.data(), zw.memory_bytes()), 0);  // atomic_number is the default
}

TEST(MolecularDensity, MatchesBruteForceAtRandomVoxels) {
  TempDir dir;
  const std::vector<Atom> atoms = random_atoms(400, 24.0, 11);
  const std::string file = write_xyz(dir, "random.xyz", atoms);
  const double sigma = 1.3;
  const Volume v = make_procedural_volume(spec_for(file, 0.7, sigma));
  const ParticleSet particles = load_particles(file, {});
  ASSERT_EQ(particles.size(), atoms.size());
  double total_weight = 0;
  for (const Atom& a : atoms) total_weight += a.z_number;
  const double truncation_bound = std::exp(-4.5) * total_weight;
  double worst_cut = 0, worst_full = 0;
  for (std::uint64_t s = 0; s < 600; ++s) {
    // Half the probes anywhere, half at voxels next to an atom (where the density is large).
    int ijk[3];
    if (s % 2 == 0) {
      for (int d = 0; d < 3; ++d)
        ijk[d] = std::min(v.dims()[static_cast<std::size_t>(d)] - 1,
                          static_cast<int>(static_cast<double>(uniform_float(77, s, static_cast<std::uint64_t>(d))) *
                                           v.dims()[static_cast<std::size_t>(d)]));
    } else {
      const Vec3 g = v.to_voxel(particles.spheres[s % atoms.size()].center);
      for (int d = 0; d < 3; ++d) ijk[d] = static_cast<int>(std::lround(g[d]));
    }
    const auto p = voxel_position(v, ijk[0], ijk[1], ijk[2]);
    double full = 0, cut = 0;
    for (std::size_t a = 0; a < atoms.size(); ++a) {
      const Vec3 c = particles.spheres[a].center;
      const double dx = p[0] - c.x, dy = p[1] - c.y, dz = p[2] - c.z, d2 = dx * dx + dy * dy + dz * dz;
      const double g = atoms[a].z_number * std::exp(-d2 / (2 * sigma * sigma));
      full += g;
      if (d2 <= 9 * sigma * sigma) cut += g;
    }
    const double got = v.value(ijk[0], ijk[1], ijk[2]);
    // Against the sum over all atoms: within the truncation bound (each atom misses at most exp(-4.5) w).
    EXPECT_LE(std::abs(got - full), truncation_bound + 1e-5 * full);
    EXPECT_LE(got, full + 1e-5 * full + 1e-6);  // truncation only ever removes density
    // Against the same truncated sum: float rounding alone.
    ASSERT_NEAR(got, cut, 1e-5 * std::max(1.0, cut)) << ijk[0] << " " << ijk[1] << " " << ijk[2];
    worst_cut = std::max(worst_cut, std::abs(got - cut));
    worst_full = std::max(worst_full, std::abs(got - full));
  }
  EXPECT_LT(worst_full, truncation_bound);
  RecordProperty("worst_vs_truncated", std::to_string(worst_cut));
  RecordProperty("worst_vs_full", std::to_string(worst_full));
}

TEST(MolecularDensity, SameBytesForOneAndTwoThreads) {
  TempDir dir;
  const std::string file = write_xyz(dir, "many.xyz", random_atoms(5000, 40.0, 5));
  const json spec = spec_for(file, 0.6, 1.1);
  std::vector<Volume> volumes;
  for (const int threads : {1, 2, 0}) {
    ThreadLimit limit(threads);
    volumes.push_back(make_procedural_volume(spec));
  }
  ASSERT_GT(volumes[0].dims()[2], 48);  // many slabs (of 4 slices), more than one task each
  for (std::size_t t = 1; t < volumes.size(); ++t) {
    ASSERT_EQ(volumes[t].dims(), volumes[0].dims());
    EXPECT_EQ(std::memcmp(volumes[t].data(), volumes[0].data(), volumes[0].memory_bytes()), 0) << "threads case " << t;
  }
}

TEST(MolecularDensity, RelativeFileIsFoundNextToTheSceneFile) {
  TempDir dir;
  write_xyz(dir, "mol.xyz", random_atoms(50, 10.0, 2));
  const json scene = json::parse(R"({
    "volumes": [ { "procedural": { "name": "molecular-density", "file": "mol.xyz", "spacing": 1.0 },
                   "transfer_function": { "preset": "grayscale" } } ] })");
  const std::string scene_path = dir.file("scene.json");
  write_file(scene_path, scene.dump());
  const Volume direct = make_procedural_volume(json{{"name", "molecular-density"}, {"file", dir.file("mol.xyz")}, {"spacing", 1.0}});
  for (const Scene& s : {build_scene(scene, std::filesystem::path(scene_path).parent_path().string()), load_scene(scene_path)}) {
    ASSERT_EQ(s.volumes.size(), 1u);
    const Volume& v = *s.volumes[0].volume;
    ASSERT_EQ(v.dims(), direct.dims());
    EXPECT_EQ(std::memcmp(v.data(), direct.data(), v.memory_bytes()), 0);
  }
  // Without a base directory the relative name is not found, and the message names it.
  const std::string e = error_of(json{{"name", "molecular-density"}, {"file", "no-such-dir-penumbra/mol.xyz"}});
  EXPECT_NE(e.find("no-such-dir-penumbra/mol.xyz"), std::string::npos) << e;
}

TEST(MolecularDensity, BadSpecsNameTheKey) {
  TempDir dir;
  const std::string file = write_xyz(dir, "two.xyz", {{"C", 0, 0, 0, 6}, {"O", 100, 0, 0, 8}});
  const auto base = [&] { return json{{"name", "molecular-density"}, {"file", file}}; };
  EXPECT_NO_THROW(make_procedural_volume(base()));
  const auto expect_names = [&](json spec, const std::vector<std::string>& needles) {
    const std::string e = error_of(spec);
    for (const std::string& n : needles) EXPECT_NE(e.find(n), std::string::npos) << "'" << n << "' missing in: " << e;
  };
  json s = base();
  s["sigmaa"] = 1;
  expect_names(s, {"molecular-density", "\"sigmaa\"", "spacing", "sigma", "padding", "weight", "file"});
  s = base();
  s["size"] = 64;
  expect_names(s, {"molecular-density", "\"size\"", "spacing"});
  for (const char* key : {"spacing", "sigma"}) {
    for (const json& bad : {json(0), json(-1), json("1.5"), json(nullptr)}) {
      s = base();
      s[key] = bad;
      expect_names(s, {"molecular-density", std::string("\"") + key + "\""});
    }
  }
  s = base();
  s["padding"] = -0.5;
  expect_names(s, {"\"padding\"", ">= 0"});
  s = base();
  s["weight"] = "mass";
  expect_names(s, {"\"weight\"", "atomic_number", "uniform"});
  s = base();
  s["weight"] = 1;
  expect_names(s, {"\"weight\""});
  s = base();
  s.erase("file");
  expect_names(s, {"\"file\"", "missing"});
  s = base();
  s["file"] = 3;
  expect_names(s, {"\"file\""});
  s = base();
  s["file"] = dir.file("absent.pdb");
  expect_names(s, {dir.file("absent.pdb")});
  // 100 Å + 2 * 4.5 Å padding at 0.1 Å: 1091 voxels along x; at 0.11 Å: 992, allowed.
  s = base();
  s["spacing"] = 0.1;
  expect_names(s, {"\"spacing\"", "1024", "\"padding\""});
  s["spacing"] = 0.11;
  s["sigma"] = 0.2;  // keeps y and z small, and the splat cheap
  s["padding"] = 4.5;
  EXPECT_EQ(make_procedural_volume(s).dims()[0], 992);
}

TEST(MolecularDensity, GroEL) {
  const std::string path = std::string(PENUMBRA_SHARED_DATA_DIR) + "/1aon.pdb.gz";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " is not there";
  const Volume v = make_procedural_volume(json{{"name", "molecular-density"}, {"file", path}});
  const ParticleSet atoms = load_particles(path, {});
  Box3 centres;
  for (const Sphere& s : atoms.spheres) centres.extend(s.center);
  const Box3 b = v.bounds();
  for (int d = 0; d < 3; ++d) {
    EXPECT_NEAR(b.lo[d], centres.lo[d] - 4.5f, 1e-3f);  // padding 3 sigma = 4.5 Å
    EXPECT_GE(b.hi[d], centres.hi[d] + 4.5f - 1e-3f);
    EXPECT_LT(b.hi[d], centres.hi[d] + 4.5f + 1.5f);
    EXPECT_LE(v.dims()[static_cast<std::size_t>(d)], 1024);
  }
  EXPECT_EQ(v.min_value(), 0.0f);
  EXPECT_GT(v.max_value(), 8.0f);   // overlapping C, N, O Gaussians
  EXPECT_LT(v.max_value(), 100.0f);
  RecordProperty("dims", std::to_string(v.dims()[0]) + "x" + std::to_string(v.dims()[1]) + "x" + std::to_string(v.dims()[2]));
}
