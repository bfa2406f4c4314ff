// Atom selections (src/penumbra/data/selection): the parser's precedence, values and errors, the name
// patterns, MDAnalysis's type guesser, periodic distances, and particles[].select in scenes (the error
// naming the key, several sets from one file, trajectories evaluated per frame). The comparison with
// MDAnalysis itself on the staged GROMACS run is tests/python/test_selection_oracle.py.
#include <gtest/gtest.h>

#include <nlohmann/json.hpp>

#include "error_message.h"
#include "penumbra/data/selection/atom_topology.h"
#include "penumbra/data/selection/name_pattern.h"
#include "penumbra/data/selection/selection.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene_io/scene_file.h"
#include "image_check.h"
#include "shared_data.h"

namespace penumbra {
namespace {

using test::error_message;
using test::max_difference;
using Indices = std::vector<std::uint32_t>;

// Six atoms on the x axis, 1 Å apart: residue 1 ALA (N CA C), residue 2 SOL (OW HW1), residue 3 NA (NA).
struct Fixture {
  AtomTopology topology;
  std::vector<Vec3> positions;
  Fixture() {
    const char* names[] = {"N", "CA", "C", "OW", "HW1", "NA"};
    const char* resnames[] = {"ALA", "ALA", "ALA", "SOL", "SOL", "NA"};
    const int resids[] = {1, 1, 1, 2, 2, 3};
    for (int i = 0; i < 6; ++i) {
      topology.add(names[i], resnames[i], guess_atom_type(names[i]), "SYSTEM", "A", resids[i], resids[i]);
      positions.push_back(Vec3{static_cast<float>(i), 0, 0});
    }
  }
  Indices select(const std::string& s, std::optional<CellDimensions> cell = std::nullopt) const {
    return parse_selection(s)->evaluate(topology, positions, cell);
  }
};

TEST(Selection, KeywordsAndValues) {
  const Fixture f;
  EXPECT_EQ(f.select("all"), (Indices{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(f.select("none"), Indices{});
  EXPECT_EQ(f.select("protein"), (Indices{0, 1, 2}));
  EXPECT_EQ(f.select("backbone"), (Indices{0, 1, 2}));
  EXPECT_EQ(f.select("water"), (Indices{3, 4}));
  EXPECT_EQ(f.select("name N NA"), (Indices{0, 5}));
  EXPECT_EQ(f.select("type NA"), (Indices{5}));
  EXPECT_EQ(f.select("type C"), (Indices{1, 2}));  // CA guessed as carbon
  EXPECT_EQ(f.select("resid 2:3"), (Indices{3, 4, 5}));
  EXPECT_EQ(f.select("resid 2 - 3"), (Indices{3, 4, 5}));
  EXPECT_EQ(f.select("resid 1 to 1"), (Indices{0, 1, 2}));
  EXPECT_EQ(f.select("resnum 3"), (Indices{5}));
  EXPECT_EQ(f.select("index 0 4:5"), (Indices{0, 4, 5}));
  EXPECT_EQ(f.select("bynum 1"), (Indices{0}));
  EXPECT_EQ(f.select("chainID A and segid SYS*"), (Indices{0, 1, 2, 3, 4, 5}));
  EXPECT_EQ(f.select("byres name OW"), (Indices{3, 4}));
  EXPECT_EQ(f.select("same resname as index 1"), (Indices{0, 1, 2}));
}

// MDAnalysis: `and` and `or` have one precedence and group left to right; `not` binds tighter;
// around, sphzone, byres and same … as take everything after them.
TEST(Selection, PrecedenceIsMDAnalysis) {
  const Fixture f;
  EXPECT_EQ(f.select("name N or name NA and resid 3"), (Indices{5}));  // (N or NA) and resid 3
  EXPECT_EQ(f.select("not name N and resid 1"), (Indices{1, 2}));      // (not N) and resid 1
  EXPECT_EQ(f.select("name N or (name NA and resid 1)"), (Indices{0}));
  EXPECT_EQ(f.select("byres name OW or index 4"), (Indices{3, 4}));  // byres (OW or HW1), not (byres OW) or HW1
  EXPECT_EQ(f.select("byres index 5 or name N"), (Indices{0, 1, 2, 5}));
}

TEST(Selection, AroundExcludesTheReferenceAndWithinKeepsIt) {
  const Fixture f;
  EXPECT_EQ(f.select("around 1 name OW"), (Indices{2, 4}));
  EXPECT_EQ(f.select("around 0.99 name OW"), Indices{});
  EXPECT_EQ(f.select("around 1 not name OW"), (Indices{3}));  // more references than tested atoms
  EXPECT_EQ(f.select("within 1 of name OW"), (Indices{2, 3, 4}));
  EXPECT_EQ(f.select("sphzone 1 resid 2"), (Indices{3, 4}));  // centre 3.5
  EXPECT_TRUE(parse_selection("around 3 protein")->depends_on_positions());
  EXPECT_FALSE(parse_selection("byres protein")->depends_on_positions());
}

// Atoms 0 and 5 are 5 Å apart, but 1 Å through the side of a 6 Å box (skewed or not).
TEST(Selection, DistancesAreMinimumImageInTheBox) {
  const Fixture f;
  EXPECT_EQ(f.select("around 1.5 index 0"), (Indices{1}));
  EXPECT_EQ(f.select("around 1.5 index 0", CellDimensions{6, 6, 6, 90, 90, 90}), (Indices{1, 5}));
  EXPECT_EQ(f.select("around 1.5 index 0", CellDimensions{6, 7, 8, 60, 60, 90}), (Indices{1, 5}));
  EXPECT_EQ(f.select("around 1.5 not index 0", CellDimensions{6, 6, 6, 90, 90, 90}), (Indices{0}));
  EXPECT_EQ(f.select("sphzone 1.5 index 0", CellDimensions{6, 6, 6, 90, 90, 90}), (Indices{0, 1, 5}));
}

TEST(Selection, NamePatternsAreFnmatch) {
  EXPECT_TRUE(matches_name_pattern("HW1", "H*"));
  EXPECT_TRUE(matches_name_pattern("HW1", "H?1"));
  EXPECT_FALSE(matches_name_pattern("HW12", "H?1"));
  EXPECT_TRUE(matches_name_pattern("CA", "[CN]A"));
  EXPECT_FALSE(matches_name_pattern("OA", "[CN]A"));
  EXPECT_TRUE(matches_name_pattern("OA", "[!CN]A"));
  EXPECT_TRUE(matches_name_pattern("C1", "C[0-9]"));
  EXPECT_FALSE(matches_name_pattern("ca", "CA"));
  EXPECT_TRUE(matches_name_pattern("[X", "[X"));  // no closing bracket: literal
  EXPECT_TRUE(matches_name_pattern("", "*"));
}

TEST(Selection, TypesGuessedAsMDAnalysis) {
  EXPECT_EQ(guess_atom_type("OW"), "O");
  EXPECT_EQ(guess_atom_type("HW1"), "H");
  EXPECT_EQ(guess_atom_type("CA"), "C");
  EXPECT_EQ(guess_atom_type("NA"), "NA");
  EXPECT_EQ(guess_atom_type("CL"), "CL");
  EXPECT_EQ(guess_atom_type("SOD"), "NA");
  EXPECT_EQ(guess_atom_type("1HB"), "H");
  EXPECT_EQ(guess_atom_type("MW"), "DUMMY");
}

TEST(Selection, MalformedSelectionsNamePositionAndExpectation) {
  EXPECT_EQ(error_message([] { parse_selection("name"); }), "at character 5: expected a value after 'name', found the end of the selection");
  EXPECT_EQ(error_message([] { parse_selection("protein CA"); }),
            "at character 9: expected 'and', 'or' or the end of the selection, found 'CA'");
  EXPECT_EQ(error_message([] { parse_selection("(protein"); }),
            "at character 9: expected ')' closing the '(' at character 1, found the end of the selection");
  EXPECT_EQ(error_message([] { parse_selection("around x protein"); }), "at character 8: expected a distance in Å (a number ≥ 0), found 'x'");
  EXPECT_EQ(error_message([] { parse_selection("resid 5A"); }),
            "at character 7: expected a residue number without an insertion code (the topology has none), found '5A'");
  EXPECT_EQ(error_message([] { parse_selection("within 3 protein"); }),
            "at character 10: expected 'of' (VMD's 'within D of SELECTION'), found 'protein'");
  EXPECT_NE(error_message([] { parse_selection("smarts c1ccccc1"); }).find("MDAnalysis's 'smarts' is not one"), std::string::npos);
  EXPECT_EQ(error_message([] { parse_selection("resid 1:"); }),
            "at character 7: expected a number or a range ('10:20', '10-20', '10 to 20') after 'resid', found '1:'");
  EXPECT_EQ(error_message([] { parse_selection("index 99999999999999999999"); }),
            "at character 7: expected a number that fits 64 bits, found '99999999999999999999'");
}

// What a viewer user may type stays within bounds: deep nesting and very long selections are refused
// (the recursion of parsing, evaluating and freeing stays shallow), long values are read.
TEST(Selection, HugeSelectionsAreRefusedOrRead) {
  EXPECT_NE(error_message([] { parse_selection(std::string(500, '(') + "all" + std::string(500, ')')); })
                .find("at character 101: expected at most 100 levels of nesting"), std::string::npos);
  std::string chain = "name A";
  for (int i = 0; i < 6000; ++i) chain += " or name A";
  EXPECT_NE(error_message([&] { parse_selection(chain); }).find("expected at most 10000 words"), std::string::npos);
  EXPECT_NE(error_message([] { parse_selection("resid " + std::string(100000, '1')); }).find("expected a number that fits 64 bits"),
            std::string::npos);
  EXPECT_NE(error_message([] { parse_selection("resid 1-" + std::string(100000, 'x')); }).find("expected a number or a range"),
            std::string::npos);
}

nlohmann::json md_particles(nlohmann::json entry) {
  entry["file"] = test::shared_data_dir() + "/md_1tii_chainD.gro";
  return entry;
}

TEST(Selection, SceneKeyNamesTheMalformedSelection) {
  SKIP_WITHOUT_SHARED_DATA("md_1tii_chainD.gro");
  nlohmann::json j;
  j["particles"] = {md_particles({{"select", "protein and"}}), md_particles({{"select", "name CA or"}})};
  j["particles"][0]["select"] = "protein";
  EXPECT_EQ(error_message([&] { build_scene(j, ""); }),
            "particles.1.select: at character 11: expected a selection (a keyword such as all, protein, name, resid, around, "
            "or '('), found the end of the selection");
  j["particles"][1]["select"] = "resname XYZ";
  EXPECT_EQ(error_message([&] { build_scene(j, ""); }),
            "particles.1.select: selects no atoms of '" + test::shared_data_dir() + "/md_1tii_chainD.gro'");
}

// Protein by chain, ions larger: several sets from one file, each with its selection; the file is
// read once per cache.
TEST(Selection, SeveralSetsFromOneFile) {
  SKIP_WITHOUT_SHARED_DATA("md_1tii_chainD.gro");
  nlohmann::json j;
  j["particles"] = {md_particles({{"select", "protein"}, {"hydrogens", false}}),
                    md_particles({{"select", "resname NA CL"}, {"radius_scale", 2}, {"color_by", "uniform"}, {"color", {1, 0, 0}}})};
  SceneDataCache cache;
  SceneReadOptions options;
  options.cache = &cache;
  const Scene s = build_scene(j, "", options);
  ASSERT_EQ(s.particles.size(), 2u);
  EXPECT_EQ(s.particles[0].selected_atoms, std::optional<std::size_t>(1470));
  EXPECT_LT(s.particles[0].set->size(), 1470u);  // hydrogens dropped after selecting
  EXPECT_EQ(s.particles[1].set->size(), *s.particles[1].selected_atoms);
  // each sphere names its atom in the file: the protein comes first in the file, the ions last
  const auto file = read_particle_file(test::shared_data_dir() + "/md_1tii_chainD.gro");
  const AtomTopology& topology = topology_of(*file);
  ASSERT_EQ(s.particles[0].set->atoms.size(), s.particles[0].set->size());
  for (const std::uint32_t a : s.particles[0].set->atoms) {
    EXPECT_LT(a, 1470u);
    EXPECT_NE(topology.strings[topology.types[a]], "H");
  }
  ASSERT_EQ(s.particles[1].set->atoms.size(), s.particles[1].set->size());
  for (const std::uint32_t a : s.particles[1].set->atoms) {
    const std::string& resname = topology.strings[topology.resnames[a]];
    EXPECT_TRUE(resname == "NA" || resname == "CL") << a << " " << resname;
  }
  int reads = 0;
  cache.particle_file(test::shared_data_dir() + "/md_1tii_chainD.gro", [&] {
    ++reads;
    return read_particle_file(test::shared_data_dir() + "/md_1tii_chainD.gro");
  });
  EXPECT_EQ(reads, 0) << "the file was not kept for the second set";
}

// A selection that depends on positions follows the frames; others keep their atoms.
TEST(Selection, TrajectorySelectionsFollowTheFrames) {
  SKIP_WITHOUT_SHARED_DATA("md_1tii_chainD.xtc");
  nlohmann::json j;
  j["particles"] = {md_particles({{"select", "around 5 protein"}, {"trajectory", test::shared_data_dir() + "/md_1tii_chainD.xtc"}}),
                    md_particles({{"select", "protein"}, {"trajectory", test::shared_data_dir() + "/md_1tii_chainD.xtc"}})};
  j["time"] = 0;
  const Scene s0 = build_scene(j, "");
  j["time"] = 150;
  const Scene s150 = build_scene(j, "");
  EXPECT_EQ(s0.particles[0].selected_atoms, std::optional<std::size_t>(2177));  // MDAnalysis's count at frame 0
  EXPECT_NE(s0.particles[0].selected_atoms, s150.particles[0].selected_atoms);
  EXPECT_EQ(s0.particles[1].set->size(), 1470u);
  EXPECT_EQ(s150.particles[1].set->size(), 1470u);
  EXPECT_EQ(s0.particles[0].set->atoms.size(), 2177u);
  EXPECT_NE(s0.particles[0].set->atoms, s150.particles[0].set->atoms);
  EXPECT_EQ(s150.particles[1].set->atoms.back(), 1469u);
}

// An assembly copies the selected atoms: `index` and every other keyword name the deposited atoms,
// and each copy names the atom it copies.
TEST(Selection, AssembliesCopyTheSelectedAtoms) {
  SKIP_WITHOUT_SHARED_DATA("3j6r.pdb.gz");
  nlohmann::json j;
  j["particles"] = {{{"file", test::shared_data_dir() + "/3j6r.pdb.gz"}, {"assembly", 1}, {"select", "chainID A and name CA"}}};
  const Scene s = build_scene(j, "");
  const std::size_t selected = *s.particles[0].selected_atoms;
  const ParticleSet& set = *s.particles[0].set;
  ASSERT_GT(selected, 0u);
  EXPECT_EQ(set.size(), 60 * selected);  // 60 operators
  ASSERT_EQ(set.atoms.size(), set.size());
  for (std::size_t k = 0; k < set.size(); ++k) EXPECT_EQ(set.atoms[k], set.atoms[k % selected]);
}

TEST(Selection, ProceduralSpheresTakeAUniformColour) {
  nlohmann::json j;
  j["particles"] = {{{"procedural", {{"name", "random-spheres"}, {"count", 10}}}, {"color_by", "uniform"}, {"color", {1, 0, 0}}}};
  const Scene s = build_scene(j, "");
  for (const std::uint32_t c : s.particles[0].set->colors) EXPECT_EQ(c, pack_rgba8(Rgb{1, 0, 0}));
  j["particles"][0]["color_by"] = "hue";
  EXPECT_EQ(error_message([&] { build_scene(j, ""); }), "particles.0.color: is used only with \"color_by\": \"uniform\"");
}

// particles[].visible: a hidden set is neither drawn nor a caster of shadows or occlusion: the frame is
// the frame without it, in every sphere technique; shown, it changes the frame.
TEST(ParticleVisibility, AHiddenSetIsNeitherDrawnNorACaster) {
  auto scene = [](bool with_upper, const nlohmann::json& upper_extra, const nlohmann::json& shadows, const std::string& ambient) {
    nlohmann::json j;
    j["camera"] = {{"eye", {0, 1.2, 2.6}}, {"target", {0, 0, 0}}, {"width", 64}, {"height", 48}};
    j["lights"] = {{{"type", "directional"}, {"direction", {-0.2, -1, -0.1}}}};
    j["planes"] = {{{"point", {0, -0.6, 0}}, {"normal", {0, 1, 0}}, {"size", 4}}};
    j["particles"] = {{{"procedural", {{"name", "random-spheres"}, {"count", 40}, {"radius", 0.06}, {"seed", 1}}},
                       {"color_by", "uniform"}, {"color", {0.9, 0.2, 0.2}}}};
    if (with_upper) {
      nlohmann::json upper = {{"procedural", {{"name", "random-spheres"}, {"count", 40}, {"radius", 0.08}, {"seed", 2}}},
                              {"color_by", "uniform"}, {"color", {0.2, 0.3, 0.9}}, {"origin", {0, 0.7, 0}}};
      upper.update(upper_extra);
      j["particles"].push_back(upper);
    }
    j["shadows"] = shadows;
    j["ambient"] = {{"technique", ambient}};
    return Renderer(build_scene(j, "")).render().image;
  };
  for (const std::string shadows : {"issm", "ray_traced"})
    for (const std::string ambient : {"none", "particle_ao"}) {
      SCOPED_TRACE(shadows + " + " + ambient);
      const nlohmann::json technique = {{"technique", shadows}};
      const Image without = scene(false, {}, technique, ambient);
      EXPECT_EQ(max_difference(scene(true, {{"visible", false}}, technique, ambient), without), 0.0);
      EXPECT_GT(max_difference(scene(true, {{"visible", true}}, technique, ambient), without), 0.05);
    }
  nlohmann::json j;
  j["particles"] = {{{"procedural", {{"name", "random-spheres"}, {"count", 4}}}, {"visible", false}, {"casts_shadows", true}}};
  EXPECT_EQ(error_message([&] { build_scene(j, ""); }),
            "particles.0.casts_shadows: the particle set is not visible ('visible': false): it neither casts nor receives shadows");
  j["particles"][0].erase("casts_shadows");
  const Scene hidden = build_scene(j, "");
  EXPECT_FALSE(hidden.has_particles());
  EXPECT_EQ(hidden.particles.at(0).set->size(), 4u);  // read, kept, not drawn
}

}  // namespace
}  // namespace penumbra
