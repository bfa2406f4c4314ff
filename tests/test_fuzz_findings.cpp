// Regression tests for what fuzzing found in the readers (issue 12 §6, fuzz/, docs/fuzzing.md). Each
// input is written here into a temporary directory. A reader must refuse bad input with an Error naming
// the file and what was wrong; before the fixes these inputs aborted, hung, exhausted memory, read out
// of bounds (visible under the sanitize preset) or escaped as library exceptions.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstring>
#include <functional>
#include <string>

#include "penumbra/core/error.h"
#include "penumbra/data/io/molecule_gemmi.h"
#include "penumbra/data/io/particle_io.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/scene_io/scene_file.h"
#include "error_message.h"
#include "test_volume_io_util.h"

using namespace penumbra;
using penumbra::test::error_message;
using penumbra::test::TempDir;
using penumbra::test::write_file;
using penumbra::test::Bytes;
using penumbra::test::nifti_file;
using penumbra::test::NiftiSpec;

namespace {

#define EXPECT_HAS(message, part) EXPECT_NE((message).find(part), std::string::npos) << "message: " << (message)

// Runs f in a child process that must finish within `seconds`: for inputs that used to make a library
// loop forever or allocate gigabytes, so that a regression fails this test instead of hanging the suite.
// Returns f's result (0 or 1) or -1 when the child was killed (time out, crash).
int in_child_within(int seconds, const std::function<int()>& f) {
  const pid_t pid = fork();
  if (pid == 0) {
    alarm(static_cast<unsigned>(seconds));
    _exit(f());
  }
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

const std::string kNrrdFields = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n";
const std::string kNrrdData(8, '\x07');

}  // namespace

// ------------------------------------------------------------------------------------------- NRRD

// teem quotes an unparsable field line in its error message, formatted into a 1025-byte stack buffer:
// a ~1000-character line aborted the program with "buffer overflow detected".
TEST(FuzzFindings, NrrdOverlongFieldLinesAreRefusedBeforeTeem) {
  TempDir dir;
  const std::string unknown = dir.file("unknown.nrrd"), kinds = dir.file("kinds.nrrd");
  write_file(unknown, kNrrdFields + "foo" + std::string(1000, 'x') + ": bar\n\n" + kNrrdData);
  std::string kinds_line = "kinds:";
  while (kinds_line.size() < 1000) kinds_line += " domain";
  write_file(kinds, kNrrdFields + kinds_line + "\n\n" + kNrrdData);
  const std::string m1 = error_message([&] { (void)load_volume(unknown); });
  EXPECT_HAS(m1, unknown);
  EXPECT_HAS(m1, "line 6");
  EXPECT_HAS(m1, "neither a NRRD field");
  const std::string m2 = error_message([&] { (void)load_volume(kinds); });
  EXPECT_HAS(m2, kinds);
  EXPECT_HAS(m2, "line 6");
  EXPECT_HAS(m2, "'kinds' line is");
  EXPECT_HAS(m2, "at most 512");
  // What is safe stays accepted: a long key:=value pair (Slicer writes those), a long comment, a short
  // kinds line.
  const std::string fine = dir.file("fine.nrrd");
  write_file(fine, kNrrdFields + "kinds: domain domain domain\n# " + std::string(3000, 'c') + "\nsegmentation:=" +
                       std::string(5000, 'v') + "\n\n" + kNrrdData);
  EXPECT_EQ(load_volume(fine).voxel_count(), 8u);
}

// teem's airOneLinify reads the byte before a comment made only of bytes it deletes (a heap
// under-read that only a sanitized teem shows, so the loader's refusal is what is tested).
TEST(FuzzFindings, NrrdCommentOfOnlyControlBytesIsRefused) {
  TempDir dir;
  const std::string bad = dir.file("comment.nrrd"), high = dir.file("high.nrrd"), fine = dir.file("fine.nrrd");
  write_file(bad, kNrrdFields + "#\x01\x02\x03\n\n" + kNrrdData);
  write_file(high, kNrrdFields + "# \xe6\x97\xa5\xe6\x9c\xac\n\n" + kNrrdData);
  const std::string m = error_message([&] { (void)load_volume(bad); });
  EXPECT_HAS(m, bad);
  EXPECT_HAS(m, "line 6");
  EXPECT_HAS(m, "comment");
  EXPECT_HAS(error_message([&] { (void)load_volume(high); }), "line 6");
  write_file(fine, kNrrdFields + "#\n# \t \n#  text \x01 with a control byte\n\n" + kNrrdData);
  EXPECT_EQ(load_volume(fine).voxel_count(), 8u);
}

// teem returns early without freeing what it allocated on these (LeakSanitizer, sanitize preset):
// per-axis fields before "dimension" (kinds, centers) and an unterminated quoted label or unit.
TEST(FuzzFindings, NrrdHeadersTeemLeaksOnAreRefused) {
  TempDir dir;
  struct Case {
    std::string header, expected;
  };
  const Case cases[] = {
      {"NRRD0004\nkinds: domain domain domain\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n", "comes before 'dimension'"},
      {"NRRD0004\ncenters: cell cell cell\ntype: uchar\ndimension: 3\nsizes: 2 2 2\nencoding: raw\n", "comes before 'dimension'"},
      {kNrrdFields + "labels: \"x\" \"y\" \"z\n", "no closing"},
      {kNrrdFields + "units: \"mm\" mm\n", "double-quoted strings"},
      {kNrrdFields + "space dimension: 3\nspace units: \"mm\" \"mm\" \"mm\n", "no closing"},
      {kNrrdFields + "space units: \"mm\" \"mm\" \"mm\"\n", "comes before 'space'"},
      // Found by fuzz_nrrd (2026-12-02): one string too many leaks the others
      {kNrrdFields + "space: left-posterior-superior\nspace units: \"mm\" \"\" \"mm\" \"mm\"\n", "found more"},
      {kNrrdFields + "labels: \"x\" \"y\" \"z\" \"w\"\n", "found more"},
      // Found by fuzz_nrrd: teem reads a line only up to a NUL byte and ends lines at a lone '\r', so it
      // saw an unterminated unit where the checks saw a complete one.
      {kNrrdFields + "space dimension: 3\nspace units: \"mm\" \"m\t" + std::string(3, '\0') + "m\" \"mm\"\n", "NUL byte"},
      {kNrrdFields + "kinds: domain domain domain\rlabels: \"x\n", "carriage return"},
      // Found by fuzz_nrrd (CI, 2026-12-02): teem refuses a block size for a non-block type and leaks
      {kNrrdFields + "block size: 40625\n", "'block size' belongs to type 'block'"},
      // Found by fuzz_nrrd (CI, 2026-12-05): teem's check after reading refuses a kind of fixed size on an
      // axis of another size, and leaks
      {kNrrdFields + "kinds: domain HSV-color domain\n", "axis 1 is of kind 'HSV-color', which has 3 samples, but its size is 2"},
  };
  for (const Case& c : cases) {
    const std::string path = dir.file("leak.nrrd");
    write_file(path, c.header + "\n" + kNrrdData);
    const std::string m = error_message([&] { (void)load_volume(path); });
    EXPECT_HAS(m, path);
    EXPECT_HAS(m, c.expected);
  }
  // Labels and units that are complete load.
  const std::string fine = dir.file("labels.nrrd");
  write_file(fine, kNrrdFields + "labels: \"x\" \"y \\\"quoted\\\"\" \"z\"\nspace: RAS\nspace units: \"mm\" \"mm\" \"mm\"\n\n" + kNrrdData);
  EXPECT_EQ(load_volume(fine).voxel_count(), 8u);
}

// ------------------------------------------------------------------------------------------ mmCIF

namespace {

std::string cif_with_oper_expression(const std::string& expr) {
  return "data_test\n"
         "_pdbx_struct_assembly.id 1\n_pdbx_struct_assembly.details author_defined_assembly\n"
         "_pdbx_struct_assembly.method_details ?\n_pdbx_struct_assembly.oligomeric_details monomeric\n"
         "_pdbx_struct_assembly.oligomeric_count 1\n"
         "_pdbx_struct_assembly_gen.assembly_id 1\n_pdbx_struct_assembly_gen.oper_expression '" + expr + "'\n"
         "_pdbx_struct_assembly_gen.asym_id_list A\n"
         "loop_\n_pdbx_struct_oper_list.id\n_pdbx_struct_oper_list.type\n"
         "_pdbx_struct_oper_list.matrix[1][1]\n_pdbx_struct_oper_list.matrix[1][2]\n_pdbx_struct_oper_list.matrix[1][3]\n"
         "_pdbx_struct_oper_list.vector[1]\n_pdbx_struct_oper_list.matrix[2][1]\n_pdbx_struct_oper_list.matrix[2][2]\n"
         "_pdbx_struct_oper_list.matrix[2][3]\n_pdbx_struct_oper_list.vector[2]\n_pdbx_struct_oper_list.matrix[3][1]\n"
         "_pdbx_struct_oper_list.matrix[3][2]\n_pdbx_struct_oper_list.matrix[3][3]\n_pdbx_struct_oper_list.vector[3]\n"
         "1 'identity operation' 1 0 0 0 0 1 0 0 0 0 1 0\n"
         "2 'translation' 1 0 0 10 0 1 0 0 0 0 1 0\n"
         "loop_\n_atom_site.group_PDB\n_atom_site.id\n_atom_site.type_symbol\n_atom_site.label_atom_id\n"
         "_atom_site.label_alt_id\n_atom_site.label_comp_id\n_atom_site.label_asym_id\n_atom_site.label_entity_id\n"
         "_atom_site.label_seq_id\n_atom_site.Cartn_x\n_atom_site.Cartn_y\n_atom_site.Cartn_z\n_atom_site.occupancy\n"
         "_atom_site.B_iso_or_equiv\n_atom_site.auth_seq_id\n_atom_site.auth_asym_id\n_atom_site.pdbx_PDB_model_num\n"
         "ATOM 1 N N . GLY A 1 1 1.0 2.0 3.0 1.0 10.0 1 A 1\n"
         "ATOM 2 C CA . GLY A 1 1 2.0 2.0 3.0 1.0 10.0 1 A 1\n#\n";
}

}  // namespace

// gemmi expands oper_expression ranges into one string per operator while it builds the structure,
// whether or not an assembly is asked for: (1-30000000) took 1.5 GB, (2147483647-2147483647) never ended.
TEST(FuzzFindings, MmcifOperatorRangesAreBoundedBeforeGemmiExpandsThem) {
  TempDir dir;
  struct Case {
    const char* expr;
    int assembly;
    const char* expected;
  };
  const Case cases[] = {{"(1-30000000)", 1, "more than 100000 operators"},
                        {"(1-30000000)", 0, "more than 100000 operators"},
                        {"(2147483647-2147483647)", 0, "beyond 2147483646"},
                        {"(1-2,99999999999)", 0, ""},  // not a range: one name, no number is parsed
                        {"(5-99999999999)", 0, "beyond 2147483646"}};
  for (const Case& c : cases) {
    const std::string path = dir.file("ops.cif");
    write_file(path, cif_with_oper_expression(c.expr));
    // In a child with a deadline: a regression loops forever or allocates gigabytes.
    const auto start = std::chrono::steady_clock::now();
    const int result = in_child_within(60, [&] {
      ParticleLoadOptions o;
      o.assembly = c.assembly;
      try {
        (void)load_particles(path, o);
        return std::string(c.expected).empty() ? 0 : 1;
      } catch (const Error& e) {
        const std::string m = e.what();
        return m.find(path) != std::string::npos && !std::string(c.expected).empty() &&
                       m.find(c.expected) != std::string::npos && m.find("oper_expression") != std::string::npos
                   ? 0
                   : 1;
      }
    });
    EXPECT_EQ(result, 0) << c.expr << " (assembly " << c.assembly << "): -1 is a crash or no end within 60 s";
    EXPECT_LT(std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count(), 10) << c.expr;
  }
  // A legal range still builds its assembly.
  const std::string path = dir.file("ok.cif");
  write_file(path, cif_with_oper_expression("(1-2)"));
  ParticleLoadOptions o;
  o.assembly = 1;
  EXPECT_EQ(load_particles(path, o).size(), 4u);
}

TEST(FuzzFindings, AssemblySphereCountIsBounded) {
  TempDir dir;
  const std::string path = dir.file("ok.cif");
  write_file(path, cif_with_oper_expression("(1-2)"));
  ParticleLoadOptions o;
  o.assembly = 1;
  o.max_spheres = 3;
  const std::string m = error_message([&] { (void)load_particles(path, o); });
  EXPECT_HAS(m, path);
  EXPECT_HAS(m, "more than 3 spheres");
}

// -------------------------------------------------------------------------------------------- PDB

namespace {

std::string pdb_with_ssbond(std::size_t columns) {
  std::string ssbond = "SSBOND   1 CYS A    1    CYS A    2                          1555   1555  2.03";
  ssbond.resize(columns, ' ');
  return ssbond + "\n" +
         "ATOM      1  SG  CYS A   1       1.000   2.000   3.000  1.00  0.00           S\n"
         "ATOM      2  SG  CYS A   2       3.000   2.000   3.000  1.00  0.00           S\n"
         "END\n";
}

}  // namespace

// gemmi 0.5.7 reads columns 74-78 of an SSBOND record (its distance) whenever the record, line break
// included, is longer than 73 characters: a 73- to 76-column record is read past its end (a heap
// over-read, reported by AddressSanitizer under the sanitize preset, where gemmi's header-only parser
// is instrumented). The loader pads such records to 80 columns before gemmi sees them.
TEST(FuzzFindings, PdbShortSsbondRecordsArePaddedForGemmi) {
  TempDir dir;
  for (std::size_t columns : {32, 72, 73, 74, 75, 76, 77, 78, 80}) {
    const std::string text = pdb_with_ssbond(columns);
    std::string padded;
    ASSERT_EQ(io_detail::pdb_text_for_gemmi(text, padded), columns < 80) << columns;
    if (columns < 80) {
      EXPECT_EQ(padded.find('\n'), 80u) << columns;
      EXPECT_EQ(padded.substr(80), text.substr(columns)) << columns;
    }
    const std::string path = dir.file("ssbond.pdb");
    write_file(path, text);
    EXPECT_EQ(load_particles(path, {}).size(), 2u) << columns;
  }
  std::string lower = "link       O   HOH A   1                 ZN    ZN A   2     1555   1555  2.\n";
  std::string padded;
  EXPECT_TRUE(io_detail::pdb_text_for_gemmi(lower, padded));
  EXPECT_EQ(padded.size(), 81u);
}

// Found by fuzz_pdb after the first fix: gemmi knows SSBOND by "SSBO" alone, and a NUL byte ends its copy
// of a line, so "SSBOxx" records and records with a NUL before column 74 were still read past their end.
TEST(FuzzFindings, PdbSsbondByFourLettersOrCutByNulIsPaddedToo) {
  TempDir dir;
  std::string four = pdb_with_ssbond(80);
  four.replace(4, 2, "xx");  // "SSBOxx"
  std::string nul = pdb_with_ssbond(80);
  nul[74] = '\0';
  for (const std::string& text : {pdb_with_ssbond(74).replace(4, 2, "xx"), nul}) {
    std::string fixed;
    ASSERT_TRUE(io_detail::pdb_text_for_gemmi(text, fixed));
    EXPECT_EQ(fixed.find('\0'), std::string::npos);
    EXPECT_EQ(fixed.find('\n'), 80u);
    const std::string path = dir.file("ssbo.pdb");
    write_file(path, text);
    EXPECT_EQ(load_particles(path, {}).size(), 2u);
  }
  std::string unchanged;
  EXPECT_FALSE(io_detail::pdb_text_for_gemmi(four, unchanged));  // 80 columns: nothing to do
}

// gemmi 0.5.7 packs the first four characters of every line into an int by shifting chars: a byte of
// 0x80 or more is a negative char, and shifting it is undefined behaviour (UBSan in the fuzzer build).
// Such bytes become '?' before gemmi sees the text.
TEST(FuzzFindings, PdbNonAsciiBytesAreReplacedForGemmi) {
  TempDir dir;
  const std::string text = "\xe9\xe9\xe9\xe9 header with Latin-1\nREMARK 999 caf\xc3\xa9\n" + pdb_with_ssbond(80).substr(81);
  std::string fixed;
  ASSERT_TRUE(io_detail::pdb_text_for_gemmi(text, fixed));
  EXPECT_EQ(fixed.substr(0, 10), "???? heade");
  EXPECT_EQ(fixed.find('\xe9'), std::string::npos);
  EXPECT_EQ(fixed.size(), text.size());
  const std::string path = dir.file("latin1.pdb");
  write_file(path, text);
  EXPECT_EQ(load_particles(path, {}).size(), 2u);
}

// -------------------------------------------------------------------------------------- scene file

namespace {

const char* kScene = R"({
  "volumes": [ { "procedural": { "name": "test-spheres", "size": 8 }, "transfer_function": { "preset": "test-spheres" } } ],
  "lights": [ { "type": "directional", "direction": [0, -1, 0], "intensity": 1 } ],
  "camera": { "width": 8, "height": 8 }
})";

}  // namespace

// A number beyond the double range used to escape as nlohmann's out_of_range naming neither the file
// nor the key; now the message has both and the line.
TEST(FuzzFindings, SceneNumberOverflowNamesFileLineAndKey) {
  TempDir dir;
  const std::string path = dir.file("overflow.json");
  std::string text = kScene;
  text.replace(text.find("\"intensity\": 1"), 14, "\"intensity\": 2e308");
  write_file(path, text);
  const std::string m = error_message([&] { (void)load_scene(path); });
  EXPECT_HAS(m, path);
  EXPECT_HAS(m, "line 3");
  EXPECT_HAS(m, "lights.0.intensity");
  EXPECT_HAS(m, "2e308");
  // A syntax error and invalid UTF-8 in the file name their key too.
  write_file(path, std::string(kScene).replace(std::string(kScene).find("\"size\": 8"), 9, "\"size\": 8x"));
  EXPECT_HAS(error_message([&] { (void)load_scene(path); }), "volumes.0.procedural.size");
  write_file(path, std::string(kScene).replace(std::string(kScene).find("test-spheres"), 12, "test-\xff"));
  const std::string utf = error_message([&] { (void)load_scene(path); });
  EXPECT_HAS(utf, "volumes.0.procedural.name");
  EXPECT_HAS(utf, "UTF-8");
}

// Invalid UTF-8 in a --set value was stored in the document and escaped as nlohmann's type_error (316)
// when a message printed the value; a --set number beyond the double range became the string "2e308".
TEST(FuzzFindings, SetValuesWithInvalidUtf8OrOverflowNameFileAndKey) {
  TempDir dir;
  const std::string path = dir.file("scene.json");
  write_file(path, std::string(kScene));
  for (const std::string& set : {std::string("shadows.technique=cssm\xff"), std::string("lights.0.color=\xc3\x28"),
                                std::string("volumes.0.procedural.name=\xed\xa0\x80")}) {
    const std::string m = error_message([&] { (void)load_scene(path, {set}); });
    EXPECT_HAS(m, path);
    EXPECT_HAS(m, set.substr(0, set.find('=')));
    EXPECT_HAS(m, "not valid UTF-8");
  }
  const std::string m = error_message([&] { (void)load_scene(path, {"lights.0.intensity=2e308"}); });
  EXPECT_HAS(m, path);
  EXPECT_HAS(m, "lights.0.intensity");
  EXPECT_HAS(m, "double range");
  EXPECT_HAS(error_message([&] { (void)load_scene(path, {"camera.wid\xfft=3"}); }), "not valid UTF-8");
  // Valid UTF-8 and plain strings still work.
  EXPECT_NO_THROW((void)load_scene(path, {"lights.0.intensity=2", "camera.width=4"}));
}

// Found by fuzz_mmcif: gemmi parses integers (here label_seq_id) with an int accumulator that overflows,
// undefined behaviour, on more digits than an int holds.
TEST(FuzzFindings, MmcifIntegersBeyondIntAreRefused) {
  TempDir dir;
  std::string text = cif_with_oper_expression("1");
  const std::string row = "ATOM 2 C CA . GLY A 1 1 ";
  text.replace(text.find(row), row.size(), "ATOM 2 C CA . GLY A 1 99999999999 ");
  const std::string path = dir.file("seq.cif");
  write_file(path, text);
  const std::string m = error_message([&] { (void)load_particles(path, {}); });
  EXPECT_HAS(m, path);
  EXPECT_HAS(m, "_atom_site.label_seq_id");
  EXPECT_HAS(m, "99999999999");
  EXPECT_HAS(m, "int range");
  // -2147483647 and leading zeros are fine.
  text = cif_with_oper_expression("1");
  text.replace(text.find(row), row.size(), "ATOM 2 C CA . GLY A 1 -000000000002147483647 ");
  write_file(path, text);
  EXPECT_EQ(load_particles(path, {}).size(), 2u);
}

// ------------------------------------------------------------------------------------------- NIfTI

namespace {

// A 4x3x2 NIfTI whose sform (code 1, RAS rows) is the given one.
std::string nifti_with_sform(const TempDir& dir, const std::array<std::array<float, 4>, 3>& rows) {
  Bytes bytes = nifti_file(NiftiSpec{}, Bytes(4 * 3 * 2 * 2, 0));
  nifti_1_header h{};
  std::memcpy(&h, bytes.data(), sizeof h);
  h.sform_code = 1;
  std::memcpy(h.srow_x, rows[0].data(), sizeof h.srow_x);
  std::memcpy(h.srow_y, rows[1].data(), sizeof h.srow_y);
  std::memcpy(h.srow_z, rows[2].data(), sizeof h.srow_z);
  std::memcpy(bytes.data(), &h, sizeof h);
  const std::string path = dir.file("sform.nii");
  write_file(path, bytes);
  return path;
}

}  // namespace

// An oblique sform whose k axis is 8e23 mm long made the resampled grid's voxel count overflow the
// integer it was cast to (UBSan: float-cast-overflow). Spacings outside 1e-12..1e12 mm are refused,
// and a grid too large to count is refused with its size, before any integer conversion.
TEST(FuzzFindings, NiftiAffinesTooLargeToResampleAreRefused) {
  TempDir dir;
  std::string path = nifti_with_sform(dir, {{{-52553.2f, -70, -77, -84}, {-66, -73, -8.21692e+23f, -87}, {94, 1, 8, 0.06f}}});
  std::string m = error_message([&] { (void)load_volume(path); });
  EXPECT_HAS(m, path);
  EXPECT_HAS(m, "spacing of 8.21692e+23 mm along k");
  // In range, oblique, but a step of 1e-9 mm over kilometres: refused by its size, not overflowed.
  path = nifti_with_sform(dir, {{{1e-9f, 0, 0, 0}, {0, 1e6f, 1e6f, 0}, {0, -1e6f, 1e6f, 0}}});
  m = error_message([&] { (void)load_volume(path); });
  EXPECT_HAS(m, path);
  EXPECT_HAS(m, "would be resampled onto an axis-aligned grid of");
  EXPECT_HAS(m, "GiB (at most 8 GiB)");
  // Small enough to allocate, but 1.5 million times the file's 24 voxels: a header error, refused
  // before 72 MB are resampled (the fuzzer ran such inputs at 21 a second).
  path = nifti_with_sform(dir, {{{0.01f, 0, 0, 0}, {0, 10, 10, 0}, {0, -10, 10, 0}}});
  m = error_message([&] { (void)load_volume(path); });
  EXPECT_HAS(m, "4x3001x3001 voxels at its finest spacing, 0.01 mm");
  EXPECT_HAS(m, "times its own 4x3x2 (at most 64 times");
}

// Found by fuzz_nrrd (2026-12-05, a timeout): a 1x2x2 NRRD whose second space direction is 4.3 million mm
// long was resampled onto 2 million x 2 x 3 voxels, under the old floor of 2^24 voxels, which took over
// 10 s in the sanitised build. A grid over 64 times the file's is refused above 2^21 voxels.
TEST(FuzzFindings, NrrdOneAbsurdSpacingIsNotResampled) {
  TempDir dir;
  const std::string path = dir.file("far.nrrd");
  write_file(path, "NRRD0005\ntype: float\ndimension: 3\nspace: left-posterior-superior\nsizes: 1 2 2\n"
                   "space directions: (1,0,5) (0,4294995,0) (0,0,2)\nendian: big\nencoding: raw\n\n" + std::string(16, '\0'));
  const std::string m = error_message([&] { (void)load_volume(path); });
  EXPECT_HAS(m, path);
  EXPECT_HAS(m, "times its own 1x2x2 (at most 64 times");
}
