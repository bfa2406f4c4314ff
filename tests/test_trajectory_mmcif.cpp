// Multi-model mmCIF trajectories (trajectory_mmcif.cpp): a small file written here by hand against the
// same frames as multi-model PDB (positions, cell, frame count identical), the atom order against the
// topology load_particles reads from the same file, the staged 20-frame PDB converted to mmCIF by gemmi's
// own writer against the PDB reader, and bad input (models of different atoms, truncated, garbage,
// mutated bytes): always a penumbra::Error naming the file, never another exception.
#include <gtest/gtest.h>

#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <initializer_list>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "gemmi_writer.h"
#include "penumbra/core/error.h"
#include "penumbra/data/io/particle_io.h"
#include "penumbra/data/io/trajectory_io.h"
#include "shared_data.h"
#include "test_volume_io_util.h"
#include "trajectory_test_util.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

struct Site {
  const char* group;
  const char* element;
  const char* name;
  const char* residue;
  const char* chain;
  int seq;
};

// Two residues of chain A (with a hydrogen) and a water in chain B.
const std::vector<Site> kSites = {{"ATOM", "N", "N", "ALA", "A", 1},  {"ATOM", "C", "CA", "ALA", "A", 1},
                                  {"ATOM", "H", "H", "ALA", "A", 1},  {"ATOM", "C", "CA", "GLY", "A", 2},
                                  {"HETATM", "O", "O", "HOH", "B", 101}};

double coord(std::size_t i, int k, int d) {
  const double x = static_cast<double>(i);
  return d == 0 ? 1.5 * x + 0.25 * k : d == 1 ? -2.0 * k + 0.125 * x : 0.001 * x * (k + 1) - 3.5;
}

const char* const kCellCif =
    "_cell.length_a 30.000\n_cell.length_b 40.000\n_cell.length_c 50.000\n"
    "_cell.angle_alpha 90.00\n_cell.angle_beta 90.00\n_cell.angle_gamma 120.00\n";

// `models` models of kSites; `skip` (model, atom) leaves that atom out, `rename` gives it another name.
std::string cif_text(int models, std::pair<int, int> skip = {-1, -1}, std::pair<int, int> rename = {-1, -1}) {
  std::string s = std::string("data_test\n") + kCellCif +
                  "loop_\n_atom_site.group_PDB\n_atom_site.id\n_atom_site.type_symbol\n_atom_site.label_atom_id\n"
                  "_atom_site.label_alt_id\n_atom_site.label_comp_id\n_atom_site.label_asym_id\n_atom_site.label_entity_id\n"
                  "_atom_site.label_seq_id\n_atom_site.pdbx_PDB_ins_code\n_atom_site.Cartn_x\n_atom_site.Cartn_y\n"
                  "_atom_site.Cartn_z\n_atom_site.occupancy\n_atom_site.B_iso_or_equiv\n_atom_site.auth_seq_id\n"
                  "_atom_site.auth_asym_id\n_atom_site.pdbx_PDB_model_num\n";
  char line[256];
  int serial = 0;
  for (int k = 0; k < models; ++k)
    for (std::size_t i = 0; i < kSites.size(); ++i) {
      const std::pair<int, int> at{k, static_cast<int>(i)};
      if (at == skip) continue;
      const Site& a = kSites[i];
      const std::string label_seq = a.seq < 100 ? std::to_string(a.seq) : ".";  // none for the water
      std::snprintf(line, sizeof line, "%s %d %s %s . %s %s 1 %s ? %.3f %.3f %.3f 1.00 0.00 %d %s %d\n", a.group, ++serial,
                    a.element, at == rename ? "CB" : a.name, a.residue, a.chain, label_seq.c_str(), coord(i, k, 0),
                    coord(i, k, 1), coord(i, k, 2), a.seq, a.chain, k + 1);
      s += line;
    }
  return s;
}

std::string pdb_text(int models) {
  std::string s = "CRYST1   30.000   40.000   50.000  90.00  90.00 120.00 P 1           1\n";
  char line[128];
  for (int k = 0; k < models; ++k) {
    std::snprintf(line, sizeof line, "MODEL     %4d\n", k + 1);
    s += line;
    for (std::size_t i = 0; i < kSites.size(); ++i) {
      const Site& a = kSites[i];
      std::snprintf(line, sizeof line, "%-6s%5zu  %-3s %3s %s%4d    %8.3f%8.3f%8.3f  1.00  0.00          %2s\n", a.group, i + 1,
                    a.name, a.residue, a.chain, a.seq, coord(i, k, 0), coord(i, k, 1), coord(i, k, 2), a.element);
      s += line;
    }
    s += "ENDMDL\n";
  }
  return s + "END\n";
}

std::vector<TrajectoryFrame> all_frames(TrajectoryReader& r) {
  std::vector<TrajectoryFrame> frames(r.frame_count());
  for (std::size_t k = 0; k < frames.size(); ++k) r.read_frame(k, frames[k]);
  return frames;
}

std::string gunzip_file(const std::string& path) {
  gzFile f = gzopen(path.c_str(), "rb");
  if (!f) return "";
  std::string text;
  char buf[1 << 16];
  for (int n; (n = gzread(f, buf, sizeof buf)) > 0;) text.append(buf, static_cast<std::size_t>(n));
  gzclose(f);
  return text;
}

}  // namespace

// Proves an mmCIF written by hand gives the same frames as the same models in PDB: frame count, positions
// (to the bit: both read the printed decimals), the _cell as the CRYST1 cell, time = step = frame index,
// plain and gzip, in any order; and that memory_bytes counts the positions it holds.
TEST(TrajectoryMmcif, SmallFileEqualsPdb) {
  TempDir dir;
  const std::string cif = dir.file("t.cif"), pdb = dir.file("t.pdb");
  write_file(cif, cif_text(3));
  write_file(dir.file("t.mmcif.gz"), gzip(read_file(cif)));
  write_file(pdb, pdb_text(3));
  EXPECT_EQ(trajectory_file_format("a.cif"), "mmcif");
  EXPECT_EQ(trajectory_file_format("a.MMCIF.gz"), "mmcif");
  auto p = open_trajectory(pdb, kSites.size());
  const std::vector<TrajectoryFrame> want = all_frames(*p);
  for (const std::string& path : {cif, dir.file("t.mmcif.gz")}) {
    auto r = open_trajectory(path, kSites.size());
    EXPECT_EQ(r->format(), "mmcif");
    ASSERT_EQ(r->frame_count(), 3u) << path;
    EXPECT_EQ(r->atom_count(), kSites.size());
    EXPECT_EQ(r->memory_bytes(), 3 * kSites.size() * 3 * sizeof(float));
    for (std::size_t k : {2u, 0u, 1u, 2u}) {
      TrajectoryFrame f;
      r->read_frame(k, f);
      EXPECT_EQ(max_diff(f.positions, want[k].positions), 0.0f) << path << " frame " << k;
      EXPECT_EQ(f.time_ps, static_cast<double>(k));
      EXPECT_EQ(f.step, static_cast<std::int64_t>(k));
      ASSERT_TRUE(f.has_box);
      EXPECT_EQ(f.box, want[k].box);
    }
    TrajectoryFrame f2;
    r->read_frame(2, f2);
    EXPECT_FLOAT_EQ(f2.positions[4].x, 6.5f);  // 1.5 * 4 + 0.25 * 2
    EXPECT_FLOAT_EQ(f2.positions[2].y, -3.75f);
  }
  // The placeholder cell 1 1 1 90 90 90 is no cell; so is a cell of '?'.
  std::string text = cif_text(2);
  text.replace(text.find("_cell.length_a 30.000"), 21, "_cell.length_a ?");
  write_file(cif, text);
  EXPECT_FALSE(all_frames(*open_trajectory(cif))[1].has_box);
  text = cif_text(2);
  for (const char* tag : {"length_a 30.000", "length_b 40.000", "length_c 50.000"}) text.replace(text.find(tag) + 9, 6, "1.0");
  text.replace(text.find("gamma 120.00"), 12, "gamma 90.0");
  write_file(cif, text);
  EXPECT_FALSE(all_frames(*open_trajectory(cif))[0].has_box);
}

// Proves frame k's atom i is sphere i of the topology load_particles reads from the same file (gemmi's
// order: an atom listed after a later residue joins its own residue), so a file can be its own topology.
TEST(TrajectoryMmcif, AtomOrderIsTheTopologysOrder) {
  TempDir dir;
  std::string text = cif_text(2);
  // Model 1's third atom (H of ALA 1) moved after GLY 2: gemmi puts it back into ALA 1.
  const std::size_t h = text.find("ATOM 3 H"), gly = text.find("ATOM 4 C");
  const std::string h_line = text.substr(h, gly - h), gly_line = text.substr(gly, text.find('\n', gly) + 1 - gly);
  text.replace(h, h_line.size() + gly_line.size(), gly_line + h_line);
  const std::string cif = dir.file("order.cif");
  write_file(cif, text);
  const ParticleSet topology = load_particles(cif, ParticleLoadOptions{});
  auto r = open_trajectory(cif, topology.spheres.size());
  const std::vector<TrajectoryFrame> frames = all_frames(*r);
  ASSERT_EQ(frames.size(), 2u);
  for (std::size_t i = 0; i < topology.spheres.size(); ++i)
    for (int d = 0; d < 3; ++d) EXPECT_EQ(frames[0].positions[i][d], topology.spheres[i].center[d]) << i;
  EXPECT_FLOAT_EQ(frames[0].positions[2].x, static_cast<float>(coord(2, 0, 0)));  // the H, third as in ALA 1
}

// Proves the staged 20-frame PDB, written as mmCIF by gemmi's own writer, reads as the PDB reader's
// frames (every atom of every frame, within 1e-3 Å) with the same cell.
TEST(TrajectoryMmcif, StagedPdbConvertedByGemmiEqualsThePdbReader) {
  SKIP_WITHOUT_SHARED_DATA("md_1tii_chainD_20frames.pdb.gz");
  const std::string pdb = shared_data_dir() + "/md_1tii_chainD_20frames.pdb.gz";
  TempDir dir;
  const std::string cif = dir.file("md_20frames.cif");
  write_file(cif, pdb_to_mmcif_with_gemmi(gunzip_file(pdb)));
  constexpr std::size_t kAtoms = 18182;
  auto p = open_trajectory(pdb, kAtoms);
  auto m = open_trajectory(cif, kAtoms);
  ASSERT_EQ(m->frame_count(), 20u);
  EXPECT_EQ(m->memory_bytes(), 20 * kAtoms * 3 * sizeof(float));
  std::printf("md_1tii_chainD_20frames as mmCIF: memory_bytes %zu\n", m->memory_bytes());
  for (std::size_t k = 0; k < 20; ++k) {
    TrajectoryFrame a, b;
    p->read_frame(k, a);
    m->read_frame(k, b);
    EXPECT_LE(max_diff(a.positions, b.positions), 1e-3f) << "frame " << k;
    ASSERT_TRUE(b.has_box);
    for (std::size_t i = 0; i < 6; ++i) EXPECT_NEAR(b.box[i], a.box[i], 1e-3) << k << " " << i;
  }
}

// Proves bad mmCIF gives an Error naming the file and what is wrong: models of different sizes or
// atoms (naming the model and the atom), the topology's atom count, truncated or garbage text, no
// data block or no _atom_site, coordinates that are not numbers; and mutated bytes never give anything
// but frames or an Error.
TEST(TrajectoryMmcif, BadInputNamesTheFileAndTheModel) {
  TempDir dir;
  const std::string cif = dir.file("bad.cif");
  write_file(cif, cif_text(3, {1, 3}));
  EXPECT_ERROR_NAMES(error_of(cif), cif, "model 2", "frame 1", "4 atoms", "holds 5");
  write_file(cif, cif_text(3, {-1, -1}, {2, 1}));
  EXPECT_ERROR_NAMES(error_of(cif), cif, "model 3", "atom 2", "'CB' of ALA", "'CA' of ALA");
  write_file(cif, cif_text(3));
  EXPECT_ERROR_NAMES(error_of(cif, 7), cif, "frame 0", "5 atoms", "7");
  const std::string whole = cif_text(3);
  write_file(cif, whole.substr(0, whole.size() - 30));  // a cut inside the last row
  EXPECT_ERROR_NAMES(error_of(cif), cif);
  write_file(cif, whole.substr(0, whole.rfind("ATOM 14 ")));  // a cut between rows: the last model is short
  EXPECT_ERROR_NAMES(error_of(cif), cif, "model 3", "3 atoms");
  const Bytes gz = gzip(Bytes(whole.begin(), whole.end()));
  write_file(dir.file("cut.cif.gz"), Bytes(gz.begin(), gz.begin() + static_cast<std::ptrdiff_t>(gz.size() / 2)));
  EXPECT_ERROR_NAMES(error_of(dir.file("cut.cif.gz")), dir.file("cut.cif.gz"), "gzip");
  write_file(cif, "this is not a CIF file \x01\x02 at all\n'");
  EXPECT_ERROR_NAMES(error_of(cif), cif);
  write_file(cif, "# only a comment\n");
  EXPECT_ERROR_NAMES(error_of(cif), cif, "no data block");
  write_file(cif, std::string("data_x\n") + kCellCif);
  EXPECT_ERROR_NAMES(error_of(cif), cif, "no atoms");
  std::string text = whole;
  text.replace(text.find(" 0.375 "), 7, " 0.3x5 ");
  write_file(cif, text);
  EXPECT_ERROR_NAMES(error_of(cif), cif, "model 1", "not finite");
  text = whole;
  text.replace(text.find("1 A 1\n"), 6, "99999999999 A 1\n");
  write_file(cif, text);
  EXPECT_ERROR_NAMES(error_of(cif), cif, "int range");

  std::mt19937 gen(7);
  int errors = 0, frames = 0;
  for (int it = 0; it < 300; ++it) {
    std::string b = whole;
    const int flips = 1 + static_cast<int>(gen() % 4);
    for (int f = 0; f < flips; ++f) b[gen() % b.size()] = static_cast<char>(gen() % 256);
    if (gen() % 5 == 0) b.resize(gen() % b.size());
    write_file(cif, b);
    (error_of(cif).empty() ? frames : errors)++;
  }
  EXPECT_GT(errors, 0);
  EXPECT_GT(frames, 0);
}
