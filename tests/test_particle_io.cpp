// Particle loaders: the real molecules in shared/data (atom counts, assemblies from PDB and mmCIF),
// radii and colours per element, the .gro and .xyz readers on small files written here, bad input of
// every kind (which must give a penumbra::Error naming the file, and the line for the text formats), and
// a fuzz loop over mutated copies of small valid files.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <iterator>
#include <filesystem>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/core/rng.h"
#include "penumbra/data/elements.h"
#include "penumbra/data/io/particle_io.h"
#include "test_scenes.h"
#include "shared_data.h"
#include "test_volume_io_util.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

const std::string kData = shared_data_dir();

ParticleSet load_particle_file(const std::string& path, const ParticleLoadOptions& o = {}, ParticleFileInfo* info = nullptr) {
  return load_particles(path, o, info);
}

// Runs load_particles, expects a penumbra::Error and returns its message ("" if none was thrown).
std::string load_error(const std::string& path, const ParticleLoadOptions& o = {}) {
  try {
    load_particle_file(path, o);
  } catch (const Error& e) {
    return e.what();
  }
  ADD_FAILURE() << "no penumbra::Error loading " << path;
  return "";
}

#define EXPECT_PARTICLE_ERROR(path, options, ...)                                               \
  do {                                                                                          \
    const std::string path_ = (path);                                                           \
    const std::string msg_ = load_error(path_, options);                                        \
    EXPECT_NE(msg_.find(path_), std::string::npos) << "message lacks the file name: " << msg_;   \
    for (const char* part_ : {__VA_ARGS__})                                                      \
      EXPECT_NE(msg_.find(part_), std::string::npos) << "message lacks '" << part_ << "': " << msg_; \
  } while (0)

ParticleLoadOptions with_assembly(int n) {
  ParticleLoadOptions o;
  o.assembly = n;
  return o;
}

// A PDB ATOM record in the wwPDB 3.3 columns.
std::string atom_line(int serial, const std::string& name, const std::string& res, char chain, int resnr, double x,
                      double y, double z, const std::string& element) {
  char buf[100];
  std::snprintf(buf, sizeof buf, "ATOM  %5d %-4s %3s %c%4d    %8.3f%8.3f%8.3f  1.00  0.00          %2s", serial,
                name.c_str(), res.c_str(), chain, resnr, x, y, z, element.c_str());
  return std::string(buf) + "\n";
}

// Two chains; assembly 1: chain A under identity and a 10 Å x shift; assembly 2: chain B alone.
std::string small_pdb() {
  std::string s =
      "HEADER    TEST\n"
      "REMARK 350 BIOMOLECULE: 1\n"
      "REMARK 350 APPLY THE FOLLOWING TO CHAINS: A\n"
      "REMARK 350   BIOMT1   1  1.000000  0.000000  0.000000        0.00000\n"
      "REMARK 350   BIOMT2   1  0.000000  1.000000  0.000000        0.00000\n"
      "REMARK 350   BIOMT3   1  0.000000  0.000000  1.000000        0.00000\n"
      "REMARK 350   BIOMT1   2  1.000000  0.000000  0.000000       10.00000\n"
      "REMARK 350   BIOMT2   2  0.000000  1.000000  0.000000        0.00000\n"
      "REMARK 350   BIOMT3   2  0.000000  0.000000  1.000000        0.00000\n"
      "REMARK 350 BIOMOLECULE: 2\n"
      "REMARK 350 APPLY THE FOLLOWING TO CHAINS: B\n"
      "REMARK 350   BIOMT1   1  0.000000 -1.000000  0.000000        0.00000\n"
      "REMARK 350   BIOMT2   1  1.000000  0.000000  0.000000        0.00000\n"
      "REMARK 350   BIOMT3   1  0.000000  0.000000  1.000000        0.00000\n";
  s += atom_line(1, "N", "ALA", 'A', 1, 1.0, 2.0, 3.0, "N");
  s += atom_line(2, "CA", "ALA", 'A', 1, 2.0, 2.0, 3.0, "C");
  s += atom_line(3, "O", "ALA", 'A', 1, 3.0, 2.0, 3.0, "O");
  s += atom_line(4, "H", "ALA", 'A', 1, 1.0, 3.0, 3.0, "H");
  s += atom_line(5, "SG", "CYS", 'B', 2, 5.0, 0.0, 0.0, "S");
  s += "END\n";
  return s;
}

std::string small_xyz() {
  return "6\ncomment line: cell 10 10 10\n"
         "C 0.0 0.0 0.0\n"
         "O 1.2 0.0 0.0 extra columns ignored\n"
         "H -1.0 0.5 0.0\n"
         "D -1.0 -0.5 0.0\n"
         "Fe 0 0 3\n"
         "Xx 0 0 -3\n";
}

std::string small_gro() {
  return "test system\n"
         "7\n"
         "    1ALA      N    1   0.100   0.200   0.300\n"
         "    1ALA     CA    2   0.150   0.200   0.300  0.1000 -0.2000  0.3000\n"
         "    1ALA     HA    3   0.150   0.250   0.300\n"
         "    2SOL     OW    4   1.000   1.000   1.000\n"
         "    3NA      NA    5   2.000   2.000   2.000\n"
         "    4CL      CL    6  -1.000   2.000   2.000\n"
         "    5SOL     MW    7   1.010   1.000   1.000\n"
         "   3.00000   3.00000   3.00000\n";
}

std::string small_cif() {
  return "data_test\n"
         "loop_\n_atom_site.group_PDB\n_atom_site.id\n_atom_site.type_symbol\n_atom_site.label_atom_id\n"
         "_atom_site.label_alt_id\n_atom_site.label_comp_id\n_atom_site.label_asym_id\n_atom_site.label_entity_id\n"
         "_atom_site.label_seq_id\n_atom_site.Cartn_x\n_atom_site.Cartn_y\n_atom_site.Cartn_z\n_atom_site.occupancy\n"
         "_atom_site.B_iso_or_equiv\n_atom_site.auth_seq_id\n_atom_site.auth_asym_id\n_atom_site.pdbx_PDB_model_num\n"
         "ATOM 1 N N . GLY A 1 1 1.0 2.0 3.0 1.0 10.0 1 A 1\n"
         "ATOM 2 C CA . GLY A 1 1 2.0 2.0 3.0 1.0 10.0 1 A 1\n"
         "HETATM 3 ZN ZN . ZN B 2 . 5.0 5.0 5.0 1.0 10.0 101 A 1\n"
         "#\n";
}

void expect_sphere(const Sphere& s, Vec3 c, float r, float tol = 1e-4f) {
  EXPECT_NEAR(s.center.x, c.x, tol);
  EXPECT_NEAR(s.center.y, c.y, tol);
  EXPECT_NEAR(s.center.z, c.z, tol);
  EXPECT_NEAR(s.radius, r, 1e-6f);
}

}  // namespace

// ---------------------------------------------------------------- real molecules in shared/data

TEST(ParticleIoData, AtomCountsOfTheRealFiles) {
  struct Case {
    const char* file;
    std::size_t atoms;
    const char* format;
  };
  for (const Case& c : {Case{"1tii.pdb", 5684, "pdb"}, Case{"1af6.pdb", 10517, "pdb"}, Case{"1aon.pdb.gz", 58870, "pdb"},
                        Case{"bace1_dppc.gro.gz", 52661, "gro"}, Case{"3sn6.cif.gz", 10274, "mmcif"},
                        Case{"4yvs.cif.gz", 26430, "mmcif"}, Case{"graphene.xyz", 960, "xyz"}}) {
    const std::string path = kData + "/" + c.file;
    if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " not found (set PENUMBRA_DATA_DIR)";
    ParticleFileInfo info;
    const ParticleSet set = load_particle_file(path, {}, &info);
    EXPECT_EQ(set.size(), c.atoms) << c.file;
    EXPECT_EQ(set.colors.size(), c.atoms) << c.file;
    EXPECT_EQ(info.atoms_in_file, c.atoms) << c.file;
    EXPECT_EQ(info.format, c.format) << c.file;
    EXPECT_EQ(info.operators, 0) << c.file;
    EXPECT_EQ(info.unknown_elements, 0u) << c.file;
    for (const Sphere& s : set.spheres) {
      ASSERT_TRUE(is_finite(s.center)) << c.file;
      ASSERT_GT(s.radius, 1.0f) << c.file;
    }
    EXPECT_FALSE(set.bounds().empty()) << c.file;
  }
}

TEST(ParticleIoData, GraphenIsCarbon) {
  SKIP_WITHOUT_SHARED_DATA("graphene.xyz");
  const ParticleSet set = load_particle_file(kData + "/graphene.xyz");
  for (std::size_t i = 0; i < set.size(); ++i) {
    ASSERT_EQ(set.spheres[i].radius, 1.70f);
    ASSERT_EQ(set.colors[i], pack_rgba8(element_color(6)));
  }
}

TEST(ParticleIoData, GroIsInAngstromAndDropsHydrogens) {
  SKIP_WITHOUT_SHARED_DATA("bace1_dppc.gro.gz");
  const ParticleSet all = load_particle_file(kData + "/bace1_dppc.gro.gz");
  // First atom: "    1MET      N    1   5.124   5.165   6.528" (nm).
  expect_sphere(all.spheres[0], {51.24f, 51.65f, 65.28f}, 1.55f, 1e-3f);
  // The box is 9.12 x 9.12 x 8.94 nm; atoms may stick out a little (periodic images are not wrapped).
  const Box3 b = all.bounds();
  EXPECT_GT(b.extent().x, 80.0f);
  EXPECT_LT(b.extent().x, 140.0f);
  // The last atom is a copper ion (residue CU1, atom CU).
  EXPECT_EQ(all.colors.back(), pack_rgba8(element_color(29)));

  const std::uint32_t white = pack_rgba8(element_color(kHydrogen));
  const auto hydrogens = static_cast<std::size_t>(std::count(all.colors.begin(), all.colors.end(), white));
  EXPECT_GT(hydrogens, 20000u);  // 13,190 waters alone have two each
  ParticleLoadOptions o;
  o.hydrogens = false;
  ParticleFileInfo info;
  const ParticleSet heavy = load_particle_file(kData + "/bace1_dppc.gro.gz", o, &info);
  EXPECT_EQ(heavy.size(), all.size() - hydrogens);
  EXPECT_EQ(info.atoms_in_file, all.size());
  EXPECT_EQ(std::count(heavy.colors.begin(), heavy.colors.end(), white), 0);
}

TEST(ParticleIoData, PdbAssembly3j6r) {
  SKIP_WITHOUT_SHARED_DATA("3j6r.pdb.gz");
  if (sanitize_scale()) GTEST_SKIP() << "1 M spheres: too slow under the sanitizers";
  ParticleFileInfo base_info;
  const ParticleSet base = load_particle_file(kData + "/3j6r.pdb.gz", {}, &base_info);
  EXPECT_EQ(base.size(), 17214u);
  ParticleFileInfo info;
  const ParticleSet cap = load_particle_file(kData + "/3j6r.pdb.gz", with_assembly(1), &info);
  // REMARK 350 BIOMOLECULE 1: 60 BIOMT operators applied to chains B, A, E, D, C, F, i.e. to every atom.
  EXPECT_EQ(info.operators, 60);
  EXPECT_EQ(info.atoms_in_file, 17214u);
  EXPECT_EQ(cap.size(), 60u * 17214u);
  EXPECT_EQ(cap.colors.size(), cap.size());
  // Operator 1 is the identity; operator 2 is a rotation about the origin (no translation), so every atom
  // keeps its distance from the origin.
  for (std::size_t i = 0; i < base.size(); i += 97) {
    expect_sphere(cap.spheres[i], base.spheres[i].center, base.spheres[i].radius);
    const Sphere& r = cap.spheres[base.size() + i];
    EXPECT_NEAR(length(r.center), length(base.spheres[i].center), 2e-3f);
    EXPECT_EQ(cap.colors[base.size() + i], base.colors[i]);
  }
  // The capsid is about 600 Å across.
  EXPECT_GT(cap.bounds().extent().x, 450.0f);
  // Only one assembly is listed.
  EXPECT_PARTICLE_ERROR(kData + "/3j6r.pdb.gz", with_assembly(2), "assembly 2", "1 assembly");
}

TEST(ParticleIoData, MmcifAssembly4yvs) {
  SKIP_WITHOUT_SHARED_DATA("4yvs.cif.gz");
  ParticleFileInfo info;
  const ParticleSet set = load_particle_file(kData + "/4yvs.cif.gz", with_assembly(1), &info);
  // pdbx_struct_assembly_gen: operators 1-12 on asym ids A-O, which hold all 26,430 atoms.
  EXPECT_EQ(info.operators, 12);
  EXPECT_EQ(set.size(), 12u * 26430u);
  const ParticleSet base = load_particle_file(kData + "/4yvs.cif.gz");
  for (std::size_t i = 0; i < base.size(); i += 101) expect_sphere(set.spheres[i], base.spheres[i].center, base.spheres[i].radius);
  // Operator 2 (2_555) is diag(-1, -1, 1).
  for (std::size_t i = 0; i < base.size(); i += 101) {
    const Vec3 c = base.spheres[i].center;
    expect_sphere(set.spheres[base.size() + i], {-c.x, -c.y, c.z}, base.spheres[i].radius);
  }
  EXPECT_PARTICLE_ERROR(kData + "/4yvs.cif.gz", with_assembly(3), "assembly 3", "1 assembly");
}

TEST(ParticleIoData, ChainColoring) {
  SKIP_WITHOUT_SHARED_DATA("1tii.pdb");
  ParticleLoadOptions o;
  o.coloring = ParticleColoring::Chain;
  const ParticleSet set = load_particle_file(kData + "/1tii.pdb", o);
  std::vector<std::uint32_t> distinct(set.colors);
  std::sort(distinct.begin(), distinct.end());
  distinct.erase(std::unique(distinct.begin(), distinct.end()), distinct.end());
  EXPECT_GE(distinct.size(), 6u);  // 1TII has seven chains
  EXPECT_EQ(set.colors.front(), pack_rgba8(chain_color(0)));
}

// ---------------------------------------------------------------- elements and palettes

TEST(ParticleElements, SymbolsRadiiAndColours) {
  EXPECT_EQ(element_from_symbol("C"), 6);
  EXPECT_EQ(element_from_symbol("cl"), 17);
  EXPECT_EQ(element_from_symbol(" FE "), 26);
  EXPECT_EQ(element_from_symbol("D"), kHydrogen);
  EXPECT_EQ(element_from_symbol("Xx"), kUnknownElement);
  EXPECT_EQ(element_from_symbol(""), kUnknownElement);
  EXPECT_STREQ(element_symbol(30), "Zn");
  for (int z = 1; z <= 54; ++z) EXPECT_EQ(element_from_symbol(element_symbol(z)), z) << element_symbol(z);
  EXPECT_FLOAT_EQ(element_vdw_radius(1), 1.20f);
  EXPECT_FLOAT_EQ(element_vdw_radius(6), 1.70f);
  EXPECT_FLOAT_EQ(element_vdw_radius(7), 1.55f);
  EXPECT_FLOAT_EQ(element_vdw_radius(8), 1.52f);
  EXPECT_FLOAT_EQ(element_vdw_radius(15), 1.80f);
  EXPECT_FLOAT_EQ(element_vdw_radius(16), 1.80f);
  EXPECT_FLOAT_EQ(element_vdw_radius(kUnknownElement), 1.70f);
  EXPECT_FLOAT_EQ(element_vdw_radius(500), 1.70f);
  // Jmol oxygen FF0D0D in linear RGB.
  const Rgb o = element_color(8);
  EXPECT_FLOAT_EQ(o.r, 1.0f);
  EXPECT_NEAR(o.g, srgb_to_linear(13.0f / 255.0f), 1e-6f);
  EXPECT_EQ(element_color(1), Rgb(1.0f));
  for (int z = 1; z <= kMaxElement; ++z) {
    EXPECT_GT(element_vdw_radius(z), 1.0f);
    EXPECT_LT(element_vdw_radius(z), 3.6f);
  }
  EXPECT_NE(chain_color(0), chain_color(1));
  EXPECT_EQ(chain_color(0), chain_color(kChainPaletteSize));
  EXPECT_EQ(residue_color_key("HOH"), kOtherResidue);
  EXPECT_NE(residue_color_key("ALA"), kOtherResidue);
  EXPECT_EQ(residue_color_key("HIE"), residue_color_key("HIS"));
  EXPECT_EQ(residue_color_key("DA5"), residue_color_key("A"));
  EXPECT_EQ(residue_color(residue_color_key("ASP")), residue_color(residue_color_key("GLU")));
  EXPECT_NE(residue_color(residue_color_key("ASP")), residue_color(residue_color_key("LYS")));
}

TEST(ParticleElements, ColoringNames) {
  for (ParticleColoring c : {ParticleColoring::Element, ParticleColoring::Chain, ParticleColoring::Residue,
                             ParticleColoring::Uniform, ParticleColoring::Scalar})
    EXPECT_EQ(particle_coloring_from_string(to_string(c)), c);
  try {
    particle_coloring_from_string("rainbow");
    ADD_FAILURE() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("element, chain, residue, uniform or scalar"), std::string::npos) << e.what();
  }
}

TEST(ParticleElements, RandomSpheres) {
  const ParticleSet a = random_spheres(1000, 0.01f, 7);
  const ParticleSet b = random_spheres(1000, 0.01f, 7);
  const ParticleSet c = random_spheres(1000, 0.01f, 8);
  ASSERT_EQ(a.size(), 1000u);
  EXPECT_EQ(a.colors, b.colors);
  EXPECT_NE(a.colors, c.colors);
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a.spheres[i].center, b.spheres[i].center);
    EXPECT_LE(std::abs(a.spheres[i].center.x), 0.5f);
    EXPECT_LE(std::abs(a.spheres[i].center.z), 0.5f);
    EXPECT_EQ(a.spheres[i].radius, 0.01f);
  }
  const Box3 box = a.bounds();
  EXPECT_GT(box.lo.x, -0.52f);
  EXPECT_LT(box.hi.y, 0.52f);
  EXPECT_LT(box.lo.x, -0.45f);
  EXPECT_TRUE(ParticleSet{}.bounds().empty());
  EXPECT_GE(a.memory_bytes(), 1000u * 20u);
}

// ---------------------------------------------------------------- small files written here

TEST(ParticleIoFiles, XyzElementsRadiiColoursAndHydrogens) {
  TempDir dir;
  const std::string path = dir.file("small.xyz");
  write_file(path, small_xyz());
  ParticleFileInfo info;
  const ParticleSet set = load_particle_file(path, {}, &info);
  ASSERT_EQ(set.size(), 6u);
  EXPECT_EQ(info.format, "xyz");
  EXPECT_EQ(info.unknown_elements, 1u);
  const int z[] = {6, 8, 1, 1, 26, kUnknownElement};
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_FLOAT_EQ(set.spheres[i].radius, element_vdw_radius(z[i])) << i;
    EXPECT_EQ(set.colors[i], pack_rgba8(element_color(z[i]))) << i;
  }
  expect_sphere(set.spheres[1], {1.2f, 0, 0}, 1.52f);
  EXPECT_FLOAT_EQ(set.spheres[4].radius, 2.44f);  // Fe, Alvarez 2013

  ParticleLoadOptions o;
  o.hydrogens = false;
  o.radius_scale = 0.5f;
  o.coloring = ParticleColoring::Uniform;
  o.uniform_color = Rgb(0.25f, 0.5f, 1.0f);
  const ParticleSet heavy = load_particle_file(path, o);
  ASSERT_EQ(heavy.size(), 4u);  // H and D dropped
  EXPECT_FLOAT_EQ(heavy.spheres[0].radius, 0.85f);
  EXPECT_EQ(heavy.colors[3], pack_rgba8(o.uniform_color));

  // An atomic number may stand for the symbol; a second frame is ignored.
  write_file(path, "2\n\n8 0 0 0\n6 1 0 0\n1\nnext frame\nC 0 0 0\n");
  const ParticleSet numbers = load_particle_file(path);
  ASSERT_EQ(numbers.size(), 2u);
  EXPECT_FLOAT_EQ(numbers.spheres[0].radius, 1.52f);
}

TEST(ParticleIoFiles, GroNanometresToAngstromAndElementHeuristic) {
  TempDir dir;
  const std::string path = dir.file("small.gro");
  write_file(path, small_gro());
  ParticleFileInfo info;
  const ParticleSet set = load_particle_file(path, {}, &info);
  ASSERT_EQ(set.size(), 7u);
  EXPECT_EQ(info.format, "gro");
  expect_sphere(set.spheres[0], {1.0f, 2.0f, 3.0f}, 1.55f);   // N, nm → Å
  expect_sphere(set.spheres[1], {1.5f, 2.0f, 3.0f}, 1.70f);   // CA of ALA: carbon, velocities ignored
  expect_sphere(set.spheres[2], {1.5f, 2.5f, 3.0f}, 1.20f);   // HA: hydrogen
  expect_sphere(set.spheres[3], {10.0f, 10.0f, 10.0f}, 1.52f);  // OW: oxygen
  expect_sphere(set.spheres[4], {20.0f, 20.0f, 20.0f}, 2.27f);  // NA in residue NA: sodium
  expect_sphere(set.spheres[5], {-10.0f, 20.0f, 20.0f}, 1.75f);  // CL in residue CL: chlorine
  EXPECT_EQ(info.unknown_elements, 1u);  // MW, a TIP4P virtual site
  EXPECT_EQ(set.colors[4], pack_rgba8(element_color(11)));

  ParticleLoadOptions o;
  o.coloring = ParticleColoring::Residue;
  const ParticleSet by_residue = load_particle_file(path, o);
  EXPECT_EQ(by_residue.colors[0], pack_rgba8(residue_color(residue_color_key("ALA"))));
  EXPECT_EQ(by_residue.colors[3], pack_rgba8(residue_color(kOtherResidue)));

  // Higher precision (%10.5f): the field width follows the decimal points.
  write_file(path, "hi-res\n1\n    1ALA      N    1   0.10000   0.20000   0.30000\n   1.0 1.0 1.0\n");
  expect_sphere(load_particle_file(path).spheres[0], {1.0f, 2.0f, 3.0f}, 1.55f);
}

TEST(ParticleIoFiles, PdbAssembliesSelectTheirChains) {
  TempDir dir;
  const std::string path = dir.file("small.pdb");
  write_file(path, small_pdb());
  ParticleFileInfo info;
  const ParticleSet base = load_particle_file(path, {}, &info);
  ASSERT_EQ(base.size(), 5u);
  EXPECT_EQ(info.format, "pdb");
  expect_sphere(base.spheres[2], {3, 2, 3}, 1.52f);
  EXPECT_FLOAT_EQ(base.spheres[4].radius, 1.80f);

  const ParticleSet a1 = load_particle_file(path, with_assembly(1), &info);
  EXPECT_EQ(info.operators, 2);
  ASSERT_EQ(a1.size(), 8u);  // chain A (4 atoms) twice
  expect_sphere(a1.spheres[0], {1, 2, 3}, 1.55f);
  expect_sphere(a1.spheres[4], {11, 2, 3}, 1.55f);

  ParticleLoadOptions o = with_assembly(1);
  o.hydrogens = false;
  EXPECT_EQ(load_particle_file(path, o).size(), 6u);

  const ParticleSet a2 = load_particle_file(path, with_assembly(2), &info);
  EXPECT_EQ(info.operators, 1);
  ASSERT_EQ(a2.size(), 1u);  // chain B rotated 90° about z
  expect_sphere(a2.spheres[0], {0, 5, 0}, 1.80f);

  EXPECT_PARTICLE_ERROR(path, with_assembly(3), "assembly 3", "2 assemblies (1-2)");
  EXPECT_PARTICLE_ERROR(path, with_assembly(-1), "assembly -1", "2 assemblies");

  o = {};
  o.coloring = ParticleColoring::Chain;
  const ParticleSet chains = load_particle_file(path, o);
  EXPECT_EQ(chains.colors[0], pack_rgba8(chain_color(0)));
  EXPECT_EQ(chains.colors[4], pack_rgba8(chain_color(1)));
  o.coloring = ParticleColoring::Residue;
  const ParticleSet residues = load_particle_file(path, o);
  EXPECT_EQ(residues.colors[0], pack_rgba8(residue_color(residue_color_key("ALA"))));
  EXPECT_EQ(residues.colors[4], pack_rgba8(residue_color(residue_color_key("CYS"))));

  // The same file gzip-compressed.
  const std::string gz = dir.file("small.pdb.gz");
  write_file(gz, gzip(read_file(path)));
  EXPECT_EQ(load_particle_file(gz, with_assembly(1)).size(), 8u);
}

// Files with more than 999 BIOMT operators (1M4X) shift the BIOMT columns by two; the fields are read
// by blanks, not columns.
TEST(ParticleIoFiles, PdbBiomtBeyond999Operators) {
  TempDir dir;
  const std::string path = dir.file("ops.pdb");
  write_file(path,
             "REMARK 350 BIOMOLECULE: 1\n"
             "REMARK 350 APPLY THE FOLLOWING TO CHAINS: A\n"
             "REMARK 350   BIOMT1   999  1.000000  0.000000  0.000000        0.00000\n"
             "REMARK 350   BIOMT2   999  0.000000  1.000000  0.000000        0.00000\n"
             "REMARK 350   BIOMT3   999  0.000000  0.000000  1.000000        0.00000\n"
             "REMARK 350   BIOMT1  1000  0.000000 -1.000000  0.000000      -49.48600\n"
             "REMARK 350   BIOMT2  1000  1.000000  0.000000  0.000000       14.99300\n"
             "REMARK 350   BIOMT3  1000  0.000000  0.000000  1.000000       32.90200\n" +
                 atom_line(1, "CA", "GLY", 'A', 1, 1.0, 2.0, 3.0, "C"));
  ParticleFileInfo info;
  const ParticleSet set = load_particle_file(path, with_assembly(1), &info);
  EXPECT_EQ(info.operators, 2);
  ASSERT_EQ(set.size(), 2u);
  expect_sphere(set.spheres[0], {1, 2, 3}, 1.70f);
  expect_sphere(set.spheres[1], {-2.0f - 49.486f, 1.0f + 14.993f, 3.0f + 32.902f}, 1.70f);

  write_file(path, "REMARK 350 BIOMOLECULE: 1\nREMARK 350 APPLY THE FOLLOWING TO CHAINS: A\n"
                   "REMARK 350   BIOMT1   1  1.0000x0  0.000000  0.000000        0.00000\n" +
                       atom_line(1, "CA", "GLY", 'A', 1, 1.0, 2.0, 3.0, "C"));
  EXPECT_PARTICLE_ERROR(path, ParticleLoadOptions{}, "line 3", "BIOMT1", "1.0000x0");
}

TEST(ParticleIoFiles, SmallMmcif) {
  TempDir dir;
  const std::string path = dir.file("small.cif");
  write_file(path, small_cif());
  ParticleFileInfo info;
  const ParticleSet set = load_particle_file(path, {}, &info);
  ASSERT_EQ(set.size(), 3u);
  EXPECT_EQ(info.format, "mmcif");
  expect_sphere(set.spheres[0], {1, 2, 3}, 1.55f);
  expect_sphere(set.spheres[2], {5, 5, 5}, 1.39f);  // Zn, Bondi
  EXPECT_PARTICLE_ERROR(path, with_assembly(1), "assembly 1", "no biological assemblies");
}

// ---------------------------------------------------------------- bad input

TEST(ParticleIoErrors, BadFilesNameTheFileAndLine) {
  TempDir dir;
  const ParticleLoadOptions none;
  auto write = [&](const std::string& name, const std::string& text) {
    const std::string path = dir.file(name);
    write_file(path, text);
    return path;
  };
  const std::string good_atom = atom_line(1, "N", "ALA", 'A', 1, 1.0, 2.0, 3.0, "N");

  EXPECT_PARTICLE_ERROR(write("truncated.pdb", "HEADER    T\n" + good_atom.substr(0, 40) + "\n"), none, "line 2", "truncated");
  std::string bad_number = good_atom;
  bad_number.replace(30, 8, "  1.2x.3");
  EXPECT_PARTICLE_ERROR(write("number.pdb", bad_number), none, "line 1", "1.2x.3", "not a number");
  std::string nan = good_atom;
  nan.replace(38, 8, "     nan");
  EXPECT_PARTICLE_ERROR(write("nan.pdb", nan), none, "line 1", "y coordinate", "finite");
  EXPECT_PARTICLE_ERROR(write("noatoms.pdb", "HEADER    NOTHING\nEND\n"), none, "no atoms");
  EXPECT_PARTICLE_ERROR(write("empty.pdb", ""), none, "empty");
  EXPECT_PARTICLE_ERROR(write("blank.cif", "\n\n  \n"), none, "empty");
  EXPECT_PARTICLE_ERROR(write("broken.cif", "data_x\nloop_\n_atom_site.id\n'unterminated\n"), none, "mmCIF");
  std::string cif_nan = small_cif();
  cif_nan.replace(cif_nan.find("2.0 2.0 3.0"), 3, "2.q");
  EXPECT_PARTICLE_ERROR(write("nan.cif", cif_nan), none, "not finite");

  EXPECT_PARTICLE_ERROR(write("empty.xyz", ""), none, "empty");
  EXPECT_PARTICLE_ERROR(write("count.xyz", "5\n\nC 0 0 0\nC 1 0 0\nC 2 0 0\n"), none, "line 6", "3 atom lines", "5 atoms");
  EXPECT_PARTICLE_ERROR(write("small.xyz", "2\n\nC 0 0 0\nC 1 0 0\nC 2 0 0\n"), none, "line 5", "atom count on line 1");
  EXPECT_PARTICLE_ERROR(write("nan.xyz", "1\n\nC 0 nan 0\n"), none, "line 3", "finite");
  EXPECT_PARTICLE_ERROR(write("inf.xyz", "1\n\nC 0 0 inf\n"), none, "line 3", "finite");
  EXPECT_PARTICLE_ERROR(write("short.xyz", "1\n\nC 0 0\n"), none, "line 3", "symbol x y z");
  EXPECT_PARTICLE_ERROR(write("word.xyz", "many\n\nC 0 0 0\n"), none, "line 1", "atom count");
  EXPECT_PARTICLE_ERROR(write("zero.xyz", "0\n\n"), none, "no atoms");

  const std::string gro_atom = "    1ALA      N    1   0.100   0.200   0.300\n";
  EXPECT_PARTICLE_ERROR(write("empty.gro", ""), none, "empty");
  EXPECT_PARTICLE_ERROR(write("count.gro", "t\n3\n" + gro_atom + gro_atom + "   1 1 1\n"), none, "line 5", "truncated");
  EXPECT_PARTICLE_ERROR(write("count2.gro", "t\n4\n" + gro_atom + gro_atom), none, "line 5", "2 atom lines", "4 atoms");
  EXPECT_PARTICLE_ERROR(write("small.gro", "t\n2\n" + gro_atom + gro_atom + gro_atom + "   1 1 1\n"), none, "line 5", "box line");
  EXPECT_PARTICLE_ERROR(write("nobox.gro", "t\n1\n" + gro_atom), none, "line 4", "box line");
  EXPECT_PARTICLE_ERROR(write("trunc.gro", "t\n1\n    1ALA      N    1   0.100   0.2\n 1 1 1\n"), none, "line 3", "truncated");
  EXPECT_PARTICLE_ERROR(write("nan.gro", "t\n1\n    1ALA      N    1   0.100     nan   0.300\n 1 1 1\n"), none, "line 3",
                        "y coordinate", "finite");
  EXPECT_PARTICLE_ERROR(write("num.gro", "t\n1\n    1ALA      N    1   0.100   0.200   0.3-0\n 1 1 1\n"), none, "line 3",
                        "z coordinate", "not a number");

  EXPECT_PARTICLE_ERROR(write("molecule.mol2", "whatever"), none, "unknown particle file extension", ".pdb", ".gro", ".gz");
  EXPECT_PARTICLE_ERROR(dir.file("missing.pdb"), none, "not found");
  std::filesystem::create_directories(dir.file("dir.pdb"));
  EXPECT_PARTICLE_ERROR(dir.file("dir.pdb"), none, "not a regular file");

  ParticleLoadOptions bad_scale;
  bad_scale.radius_scale = 0;
  EXPECT_PARTICLE_ERROR(write("ok.xyz", small_xyz()), bad_scale, "radius_scale");
  ParticleLoadOptions no_h;
  no_h.hydrogens = false;
  EXPECT_PARTICLE_ERROR(write("h.xyz", "1\n\nH 0 0 0\n"), no_h, "no atoms left");
  EXPECT_PARTICLE_ERROR(write("asm.xyz", small_xyz()), with_assembly(1), "no biological assemblies");
}

TEST(ParticleIoErrors, CorruptGzip) {
  TempDir dir;
  const std::string text = small_pdb();
  const Bytes packed = gzip(Bytes(text.begin(), text.end()));
  const std::string truncated = dir.file("truncated.pdb.gz");
  write_file(truncated, Bytes(packed.begin(), packed.begin() + static_cast<std::ptrdiff_t>(packed.size() / 2)));
  EXPECT_PARTICLE_ERROR(truncated, ParticleLoadOptions{}, "gzip");
  Bytes flipped = packed;
  for (std::size_t i = 20; i < flipped.size() - 10; i += 7) flipped[i] ^= 0x5a;
  const std::string corrupt = dir.file("corrupt.xyz.gz");
  write_file(corrupt, flipped);
  EXPECT_PARTICLE_ERROR(corrupt, ParticleLoadOptions{}, "gzip");
  const std::string plain = dir.file("plain.gro.gz");
  write_file(plain, small_gro());
  EXPECT_PARTICLE_ERROR(plain, ParticleLoadOptions{}, "not gzip data");
  const std::string empty = dir.file("empty.pdb.gz");
  write_file(empty, gzip(Bytes{}));
  EXPECT_PARTICLE_ERROR(empty, ParticleLoadOptions{}, "empty");
}

// Mutated copies of small valid files (truncated, bytes flipped, garbage inserted, lines duplicated or
// dropped): every load must return or throw penumbra::Error — no crash, hang or other exception.
TEST(ParticleIoErrors, FuzzMutatedFiles) {
  TempDir dir;
  struct Base {
    const char* name;
    std::string text;
  };
  const std::vector<Base> bases{{"f.pdb", small_pdb()}, {"f.xyz", small_xyz()}, {"f.gro", small_gro()}, {"f.cif", small_cif()}};
  const int rounds = sanitize_scale() ? 80 : 300;
  static const char* kGarbage[] = {"nan", "\n", "\0", "-", ".", "1e999", "ATOM  ", "REMARK 350   BIOMT1   3", "99999999999",
                                   "\r\n", " ", "MODEL        2\n", "ENDMDL\n", "loop_\n", "'", "data_"};
  int loaded = 0, rejected = 0;
  for (const Base& base : bases) {
    for (int round = 0; round < rounds; ++round) {
      std::string t = base.text;
      const std::uint64_t seed = hash_keys(12345, static_cast<std::uint64_t>(round), base.text.size());
      auto pick = [&](std::uint64_t k, std::size_t n) { return n == 0 ? 0 : static_cast<std::size_t>(mix64(seed + k) % n); };
      const int edits = 1 + static_cast<int>(pick(99, 4));
      for (int e = 0; e < edits; ++e) {
        const auto k = static_cast<std::uint64_t>(e) * 16;
        const std::size_t pos = pick(k + 1, t.size() + 1);
        switch (pick(k + 2, 5)) {
          case 0: t.resize(pos); break;
          case 1:
            if (!t.empty()) t[std::min(pos, t.size() - 1)] = static_cast<char>(pick(k + 3, 256));
            break;
          case 2: {
            const char* g = kGarbage[pick(k + 3, std::size(kGarbage))];
            t.insert(pos, std::string(g, std::max<std::size_t>(1, std::strlen(g))));
            break;
          }
          case 3: {  // duplicate or drop a line
            const std::size_t start = t.rfind('\n', pos == 0 ? 0 : pos - 1);
            const std::size_t b = start == std::string::npos ? 0 : start + 1;
            const std::size_t end = std::min(t.size(), t.find('\n', b) == std::string::npos ? t.size() : t.find('\n', b) + 1);
            const std::string line = t.substr(b, end - b);
            if (pick(k + 4, 2) == 0) t.insert(b, line); else t.erase(b, end - b);
            break;
          }
          default: t.erase(pos, pick(k + 5, 8)); break;
        }
      }
      const std::string path = dir.file(std::to_string(round) + base.name);
      write_file(path, t);
      for (int assembly : {0, 1}) {
        try {
          const ParticleSet set = load_particle_file(path, with_assembly(assembly));
          for (const Sphere& s : set.spheres) ASSERT_TRUE(is_finite(s.center)) << path;
          ++loaded;
        } catch (const Error& e) {
          ASSERT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
          ++rejected;
        } catch (const std::exception& e) {
          FAIL() << "non-penumbra exception for " << path << ": " << e.what() << "\n" << t;
        }
      }
      std::filesystem::remove(path);
    }
  }
  EXPECT_GT(loaded, 0);
  EXPECT_GT(rejected, 0);
}

TEST(ParticleIoFiles, ScalarColoringMapsTheValueRangeThroughTheColourMap) {
  TempDir dir;
  const std::string pdb = dir.file("small.pdb");
  write_file(pdb, small_pdb());
  // a two-point map from black to white over [lo, hi]: the colour is the normalised value
  ParticleLoadOptions o;
  o.coloring = ParticleColoring::Scalar;
  o.scalar = ParticleScalar::Index;
  float seen_lo = -1, seen_hi = -1;
  o.color_map = [&](float lo, float hi) {
    seen_lo = lo;
    seen_hi = hi;
    return TransferFunction({{lo, Rgb(0.0f), 1}, {hi, Rgb(1.0f), 1}});
  };
  ParticleFileInfo info;
  const ParticleSet set = load_particle_file(pdb, o, &info);
  ASSERT_EQ(set.size(), 5u);
  EXPECT_EQ(seen_lo, 0.0f);
  EXPECT_EQ(seen_hi, 4.0f);
  EXPECT_EQ(info.scalar_max, 4.0f);
  for (std::size_t i = 0; i < 5; ++i)
    EXPECT_EQ(set.colors[i], pack_rgba8(Rgb(static_cast<float>(i) / 4.0f))) << i;
  // the B-factor of a PDB file; its range is that of the atoms kept
  o.scalar = ParticleScalar::BFactor;
  load_particle_file(pdb, o, &info);
  EXPECT_LE(info.scalar_min, info.scalar_max);
  // formats without B-factors say so; the index works everywhere
  const std::string xyz = dir.file("small.xyz");
  write_file(xyz, small_xyz());
  EXPECT_PARTICLE_ERROR(xyz, o, "B-factors", "index");
  o.scalar = ParticleScalar::Index;
  EXPECT_EQ(load_particle_file(xyz, o).size(), 6u);
}

TEST(ParticleIoData, BFactorColoringOf1tii) {
  SKIP_WITHOUT_SHARED_DATA("1tii.pdb");
  ParticleLoadOptions o;
  o.coloring = ParticleColoring::Scalar;
  ParticleFileInfo info;
  const ParticleSet set = load_particle_file(kData + "/1tii.pdb", o, &info);
  EXPECT_GT(info.scalar_max, info.scalar_min + 10.0f);  // B-factors spread over tens of Å²
  // the default map runs from blue (low) to red (high): both ends occur
  bool blue = false, red = false;
  for (std::uint32_t c : set.colors) {
    const Rgb rgb = unpack_rgb8(c);
    blue |= rgb.b > 0.4f && rgb.r < 0.1f;
    red |= rgb.r > 0.4f && rgb.b < 0.05f;
  }
  EXPECT_TRUE(blue);
  EXPECT_TRUE(red);
}

// The colour key: per colour, the names it stands for and the spheres that have it, most first.
const ColorKey::Entry* key_entry(const ColorKey& key, const std::string& label) {
  for (const auto& e : key.entries)
    if (e.label == label) return &e;
  return nullptr;
}

TEST(ParticleColorKey, NamesAndCountsOfEveryColouring) {
  TempDir dir;
  const std::string gro = dir.file("small.gro");
  write_file(gro, small_gro());
  const ParticleSet by_element = load_particle_file(gro);
  EXPECT_EQ(by_element.color_key.by, "element");
  std::size_t total = 0;
  for (const auto& e : by_element.color_key.entries) total += e.count;
  EXPECT_EQ(total, by_element.size());
  const ColorKey::Entry* sodium = key_entry(by_element.color_key, "Na");
  ASSERT_NE(sodium, nullptr);
  EXPECT_EQ(sodium->count, 1u);
  EXPECT_EQ(sodium->color, pack_rgba8(element_color(11)));
  // every entry's colour is the colour of the spheres it counts
  for (const auto& e : by_element.color_key.entries)
    EXPECT_EQ(static_cast<std::size_t>(std::count(by_element.colors.begin(), by_element.colors.end(), e.color)), e.count) << e.label;
  for (std::size_t i = 1; i < by_element.color_key.entries.size(); ++i)
    EXPECT_GE(by_element.color_key.entries[i - 1].count, by_element.color_key.entries[i].count);

  // residues: ALA has its colour; SOL, NA and CL share the grey of every other residue
  ParticleLoadOptions o;
  o.coloring = ParticleColoring::Residue;
  const ParticleSet by_residue = load_particle_file(gro, o);
  ASSERT_EQ(by_residue.color_key.entries.size(), 2u);
  EXPECT_EQ(by_residue.color_key.entries[0].label, "SOL, CL, NA");  // 4 spheres: names by count, then by name
  EXPECT_EQ(by_residue.color_key.entries[0].count, 4u);
  EXPECT_EQ(by_residue.color_key.entries[0].color, pack_rgba8(residue_color(kOtherResidue)));
  EXPECT_EQ(by_residue.color_key.entries[1].label, "ALA");
  EXPECT_EQ(by_residue.color_key.entries[1].count, 3u);

  // chains, and an assembly's copies counted as often as they are drawn
  const std::string pdb = dir.file("small.pdb");
  write_file(pdb, small_pdb());
  o.coloring = ParticleColoring::Chain;
  const ParticleSet by_chain = load_particle_file(pdb, o);
  ASSERT_NE(key_entry(by_chain.color_key, "A"), nullptr);
  EXPECT_EQ(key_entry(by_chain.color_key, "A")->count, 4u);
  EXPECT_EQ(key_entry(by_chain.color_key, "B")->count, 1u);
  o.assembly = 1;  // chain A twice
  const ParticleSet assembly = load_particle_file(pdb, o);
  ASSERT_EQ(assembly.color_key.entries.size(), 1u);
  EXPECT_EQ(assembly.color_key.entries[0].count, 8u);

  // one colour; and a scalar colouring: its quantity, range and the map sampled from lo to hi
  o = {};
  o.coloring = ParticleColoring::Uniform;
  const ParticleSet uniform = load_particle_file(pdb, o);
  ASSERT_EQ(uniform.color_key.entries.size(), 1u);
  EXPECT_EQ(uniform.color_key.entries[0].count, 5u);
  o.coloring = ParticleColoring::Scalar;
  o.scalar = ParticleScalar::Index;
  o.color_map = [](float lo, float hi) { return TransferFunction({{lo, Rgb(0.0f), 1}, {hi, Rgb(1.0f), 1}}); };
  const ParticleSet scalar = load_particle_file(pdb, o);
  EXPECT_EQ(scalar.color_key.quantity, "index");
  EXPECT_EQ(scalar.color_key.lo, 0.0f);
  EXPECT_EQ(scalar.color_key.hi, 4.0f);
  ASSERT_EQ(scalar.color_key.ramp.size(), ColorKey::kRampSize);
  EXPECT_EQ(scalar.color_key.ramp.front(), pack_rgba8(Rgb(0.0f)));
  EXPECT_EQ(scalar.color_key.ramp.back(), pack_rgba8(Rgb(1.0f)));
  EXPECT_TRUE(scalar.color_key.entries.empty());
}

TEST(ParticleColorKey, RecountKeepsTheColoursPickedAndDropsTheOthers) {
  ColorKey key = categorical_color_key("chain", {1, 1, 2, 3, 3, 3}, [](std::size_t k) { return k < 2 ? 0u : k < 3 ? 1u : 2u; },
                                       [](std::uint32_t id) { return std::string(1, static_cast<char>('A' + id)); });
  ASSERT_EQ(key.entries.size(), 3u);
  EXPECT_EQ(key.entries[0].label, "C");
  recount(key, {1, 2, 2, 7});  // 7: a colour the key does not know, not counted
  ASSERT_EQ(key.entries.size(), 2u);
  EXPECT_EQ(key.entries[0].label, "B");
  EXPECT_EQ(key.entries[0].count, 2u);
  EXPECT_EQ(key.entries[1].label, "A");
  // names beyond four are counted, not listed
  const ColorKey many = categorical_color_key("residue", {5, 5, 5, 5, 5, 5}, [](std::size_t k) { return static_cast<std::uint32_t>(k); },
                                              [](std::uint32_t id) { return "R" + std::to_string(id); });
  ASSERT_EQ(many.entries.size(), 1u);
  EXPECT_EQ(many.entries[0].label, "R0, R1, R2, R3, +2 more");
}

// The periodic cell a file stores, as cell vectors (MDAnalysis's triclinic_vectors): the GRO box line
// (nm → Å), a PDB CRYST1; none for a placeholder 1 Å cell or a file without one; an assembly has none.
TEST(ParticleColorKey, PeriodicCellOfTheFile) {
  TempDir dir;
  const std::string gro = dir.file("small.gro");
  write_file(gro, small_gro());
  const ParticleSet set = load_particle_file(gro);
  ASSERT_TRUE(set.box.has_value());
  EXPECT_NEAR(set.box->a.x, 30.0f, 1e-4f);
  EXPECT_NEAR(set.box->b.y, 30.0f, 1e-4f);
  EXPECT_NEAR(set.box->c.z, 30.0f, 1e-4f);
  EXPECT_NEAR(length(set.box->a - Vec3{30, 0, 0}) + length(set.box->origin), 0.0f, 1e-4f);

  const std::string pdb = dir.file("cell.pdb");
  write_file(pdb, "CRYST1   40.000   50.000   60.000  90.00 120.00  90.00 P 1           1\n" + small_pdb());
  const ParticleSet crystal = load_particle_file(pdb);
  ASSERT_TRUE(crystal.box.has_value());
  EXPECT_NEAR(length(crystal.box->a), 40.0f, 1e-3f);
  EXPECT_NEAR(length(crystal.box->b), 50.0f, 1e-3f);
  EXPECT_NEAR(length(crystal.box->c), 60.0f, 1e-3f);
  EXPECT_NEAR(dot(crystal.box->a, crystal.box->c) / (40.0f * 60.0f), std::cos(120.0f * 3.14159265f / 180.0f), 1e-4f);  // beta
  EXPECT_FALSE(load_particle_file(pdb, with_assembly(1)).box.has_value());
  write_file(pdb, "CRYST1    1.000    1.000    1.000  90.00  90.00  90.00 P 1           1\n" + small_pdb());
  EXPECT_FALSE(load_particle_file(pdb).box.has_value());
  write_file(pdb, small_pdb());
  EXPECT_FALSE(load_particle_file(pdb).box.has_value());
}
