// PDB and mmCIF through gemmi, packed into flat per-atom arrays with the assembly operators beside
// them. gemmi is lenient about numbers (a PDB coordinate field "1.2x" reads as 1.2, a malformed mmCIF
// number as NaN), so PDB coordinate columns are checked here first, with line numbers, and every
// position read is checked to be finite. PDB assemblies (REMARK 350) are read here too, by fields
// rather than gemmi's fixed columns, which misread files with more than 999 BIOMT operators; mmCIF
// assemblies (pdbx_struct_assembly_gen + pdbx_struct_oper_list) come from gemmi.
#include "penumbra/data/io/molecule_gemmi.h"

#include <cctype>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <exception>
#include <string>
#include <unordered_map>

#include "penumbra/core/error.h"
#include "penumbra/data/io/text_fields.h"

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wpedantic"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#include <gemmi/cif.hpp>
#include <gemmi/mmcif.hpp>
#include <gemmi/model.hpp>
#include <gemmi/pdb.hpp>
#pragma GCC diagnostic pop

namespace penumbra::io_detail {

namespace {

bool starts_with_ci(std::string_view line, std::string_view prefix) {
  if (line.size() < prefix.size()) return false;
  for (std::size_t i = 0; i < prefix.size(); ++i)
    if (std::toupper(static_cast<unsigned char>(line[i])) != prefix[i]) return false;
  return true;
}

// A PDB coordinate field (8 columns, wwPDB format 3.3 "Real(8.3)"): blanks around one finite number.
void check_pdb_coordinate(std::string_view field, const char* axis, int first_column, std::size_t line_no) {
  const std::string where = "line " + std::to_string(line_no) + ": " + axis + " coordinate (columns " +
                            std::to_string(first_column) + "-" + std::to_string(first_column + 7) + ")";
  if (trim(field).empty()) throw Error(where + " is blank");
  double v = 0;
  if (!parse_number(field, v)) throw Error(where + " '" + printable(field) + "' is not a number");
  if (!std::isfinite(v)) throw Error(where + " '" + printable(field) + "' is not a finite number");
}

// The blank- or comma-separated fields of a REMARK 350 record.
std::vector<std::string_view> tokens(std::string_view s) { return split_fields(s, " \t,"); }

// One REMARK 350 record (the text after "REMARK 350"), added to `assemblies`. BIOMT rows are read as
// blank-separated fields rather than by the fixed columns of the format, which files with more than 999
// operators (1M4X) overflow: "BIOMT1  1001 -0.023929 -0.217900 ..." is shifted two columns.
void read_remark_350(std::string_view rest, std::size_t line_no, std::vector<MoleculeAssembly>& assemblies,
                     AssemblyOperator& pending) {
  const auto fail = [&](const std::string& what) {
    throw Error("line " + std::to_string(line_no) + ": REMARK 350 " + what);
  };
  const std::size_t first = rest.find_first_not_of(' ');
  if (first == std::string_view::npos) return;
  rest.remove_prefix(first);
  if (rest.substr(0, 12) == "BIOMOLECULE:") {
    const auto t = tokens(rest.substr(12));
    assemblies.emplace_back().name = t.empty() ? std::to_string(assemblies.size()) : std::string(t[0]);
  } else if (rest.substr(0, 30) == "APPLY THE FOLLOWING TO CHAINS:" || rest.substr(0, 11) == "AND CHAINS:") {
    if (assemblies.empty()) return;  // chains before any BIOMOLECULE: ignored, as gemmi does
    std::vector<AssemblyGenerator>& gens = assemblies.back().generators;
    const bool apply = rest[0] == 'A' && rest[1] == 'P';
    if (apply) gens.emplace_back();
    if (gens.empty()) return;
    for (std::string_view chain : tokens(rest.substr(rest.find(':') + 1)))
      gens.back().units.emplace_back(chain);
  } else if (rest.substr(0, 5) == "BIOMT" && rest.size() > 5) {
    const int row = rest[5] - '1';
    if (row < 0 || row > 2) fail("BIOMT record: expected BIOMT1, BIOMT2 or BIOMT3");
    const auto t = tokens(rest.substr(6));
    if (t.size() < 5) fail("BIOMT" + std::to_string(row + 1) + " record: expected the operator number and four numbers");
    for (int c = 0; c < 4; ++c) {
      double v = 0;
      if (!parse_number(t[static_cast<std::size_t>(1 + c)], v) || !std::isfinite(v))
        fail("BIOMT" + std::to_string(row + 1) + " record: '" + std::string(t[static_cast<std::size_t>(1 + c)]) +
             "' is not a finite number");
      pending[static_cast<std::size_t>(4 * row + c)] = v;
    }
    if (row == 2 && !assemblies.empty() && !assemblies.back().generators.empty()) {
      assemblies.back().generators.back().operators.push_back(pending);
      pending = AssemblyOperator{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
    }
  }
}

// Checks the ATOM/HETATM records up to the END record: each must reach column 54 and hold three finite
// coordinates (wwPDB format 3.3: x in columns 31-38, y 39-46, z 47-54); record names are matched on
// their first four letters, any case, as gemmi does. Returns the assemblies of the REMARK 350 records.
std::vector<MoleculeAssembly> scan_pdb(std::string_view text) {
  std::vector<MoleculeAssembly> assemblies;
  AssemblyOperator pending{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0};
  LineReader lines(text);
  std::string_view line;
  while (lines.next(line)) {
    const std::size_t line_no = lines.line_no();
    if (starts_with_ci(line, "END") && (line.size() == 3 || line[3] == ' ')) break;
    if (line.substr(0, 10) == "REMARK 350") {
      read_remark_350(line.substr(10), line_no, assemblies, pending);
      continue;
    }
    if (!starts_with_ci(line, "ATOM") && !starts_with_ci(line, "HETA")) continue;
    if (line.size() < 54)
      throw Error("line " + std::to_string(line_no) + ": ATOM/HETATM record is truncated (" +
                  std::to_string(line.size()) + " columns; the coordinates need columns 31-54)");
    check_pdb_coordinate(line.substr(30, 8), "x", 31, line_no);
    check_pdb_coordinate(line.substr(38, 8), "y", 39, line_no);
    check_pdb_coordinate(line.substr(46, 8), "z", 47, line_no);
  }
  return assemblies;
}

// gemmi expands every pdbx_struct_assembly_gen.oper_expression while it builds the structure, even when
// no assembly is asked for: "(1-30000000)" becomes thirty million strings (1.5 GB), and a range ending
// at 2147483647 never ends (its int counter overflows). Each expression is measured first, exactly as
// gemmi 0.5.7's parse_operation_expr walks it (the first bracket only; "a-b" ranges of no_sign_atoi
// numbers), and refused when it names more operators than an assembly can sensibly have.
constexpr std::int64_t kMaxOperatorNames = 100000;

std::int64_t leading_number(const std::string& s, std::size_t pos) {  // gemmi::no_sign_atoi, without overflow
  while (pos < s.size() && std::isspace(static_cast<unsigned char>(s[pos]))) ++pos;
  std::int64_t n = 0;
  for (; pos < s.size() && s[pos] >= '0' && s[pos] <= '9'; ++pos) n = std::min<std::int64_t>(n * 10 + (s[pos] - '0'), INT64_MAX / 16);
  return n;
}

void check_operation_expression(const std::string& expr, const std::string& assembly) {
  const auto fail = [&](const std::string& what) {
    throw Error("assembly " + printable(assembly, 40) + ": oper_expression '" + printable(expr, 60) + "' " + what);
  };
  if (expr.empty()) return;
  std::size_t start = 0, close_br = std::string::npos;
  if (expr[0] == '(') {
    start = 1;
    close_br = expr.find(')');
  }
  std::int64_t names = 0;
  for (;;) {
    const std::size_t sep = std::min(expr.find(',', start), close_br);
    const std::size_t minus = expr.find('-', start);
    if (minus < sep) {
      const std::int64_t lo = leading_number(expr, start), hi = leading_number(expr, minus + 1);
      if (lo > INT32_MAX || hi >= INT32_MAX) fail("holds an operator number beyond 2147483646");
      if (hi >= lo) names += hi - lo + 1;
    } else {
      ++names;
    }
    if (names > kMaxOperatorNames)
      fail("names more than " + std::to_string(kMaxOperatorNames) + " operators (expected a list or range of operator ids)");
    if (sep == close_br || sep == std::string::npos) break;
    start = sep + 1;
  }
}

// gemmi 0.5.7 reads integers (sequence ids, serials, charges, counts) with an int accumulator and no
// overflow check: a value whose leading digits exceed the int range is undefined behaviour (signed
// overflow, found by fuzz_mmcif). No field of a real file holds such a number, so one is refused, with
// its tag and line. Leading blanks and a sign are skipped as gemmi does; the digits are read as far as
// they go (gemmi also reads "123abc" as 123 where it does not check the whole value).
void check_integer_ranges(const gemmi::cif::Document& doc) {
  const auto check = [](const std::string& value, const std::string& tag, int line) {
    std::size_t i = 0;
    while (i < value.size() && (value[i] == ' ' || value[i] == '\t')) ++i;
    if (i < value.size() && (value[i] == '-' || value[i] == '+')) ++i;
    std::int64_t n = 0;
    for (; i < value.size() && value[i] >= '0' && value[i] <= '9'; ++i) {
      n = n * 10 + (value[i] - '0');
      if (n > INT32_MAX)
        throw Error("line " + std::to_string(line) + ": " + printable(tag, 60) + " value '" + printable(value, 40) +
                    "' holds a number beyond the int range");
    }
  };
  for (const gemmi::cif::Block& block : doc.blocks)
    for (const gemmi::cif::Item& item : block.items) {
      if (item.type == gemmi::cif::ItemType::Pair) {
        check(item.pair[1], item.pair[0], item.line_number);
      } else if (item.type == gemmi::cif::ItemType::Loop && !item.loop.tags.empty()) {
        for (std::size_t v = 0; v < item.loop.values.size(); ++v)
          check(item.loop.values[v], item.loop.tags[v % item.loop.tags.size()], item.line_number);
      }
    }
}

void check_assembly_generators(const gemmi::cif::Document& doc) {
  for (const gemmi::cif::Block& const_block : doc.blocks) {
    auto& block = const_cast<gemmi::cif::Block&>(const_block);  // Block::find is not const in gemmi 0.5.7
    for (const auto row : block.find("_pdbx_struct_assembly_gen.", {"assembly_id", "oper_expression"}))
      check_operation_expression(row.str(1), row.str(0));
  }
}

gemmi::Structure parse_structure(std::string_view text, MoleculeFormat format, const std::string& name) {
  if (format == MoleculeFormat::Pdb) {
    std::string fixed;
    if (pdb_text_for_gemmi(text, fixed)) return gemmi::read_pdb_from_memory(fixed.data(), fixed.size(), name);
    return gemmi::read_pdb_from_memory(text.data(), text.size(), name);
  }
  const gemmi::cif::Document doc = gemmi::cif::read_memory(text.data(), text.size(), name.c_str());
  if (doc.blocks.empty()) throw Error("no data block (expected mmCIF: data_… with _atom_site)");
  check_integer_ranges(doc);
  check_assembly_generators(doc);
  return gemmi::make_structure(doc);
}

std::uint32_t index_of(const std::string& key, std::unordered_map<std::string, std::uint32_t>& index,
                       std::vector<std::string>& names) {
  const auto [it, inserted] = index.emplace(key, static_cast<std::uint32_t>(names.size()));
  if (inserted) names.push_back(key);
  return it->second;
}

PackedMolecule pack(const gemmi::Structure& st, MoleculeFormat format) {
  if (st.models.empty()) throw Error("no atoms (no ATOM/HETATM records or _atom_site rows)");
  const gemmi::Model& model = st.models.front();
  std::size_t count = 0;
  for (const gemmi::Chain& chain : model.chains)
    for (const gemmi::Residue& res : chain.residues) count += res.atoms.size();
  if (count == 0) throw Error("no atoms (no ATOM/HETATM records or _atom_site rows)");

  PackedMolecule m;
  m.reserve(count);
  std::unordered_map<std::string, std::uint32_t> chain_index, unit_index;
  const bool pdb = format == MoleculeFormat::Pdb;
  // MDAnalysis's PDB parser: the segment ids (columns 73-76), or the chain ids where no atom has one
  bool any_segment = false;
  for (const gemmi::Chain& chain : model.chains)
    for (const gemmi::Residue& res : chain.residues) any_segment = any_segment || !res.segment.empty();
  if (st.cell.is_crystal() && !(st.cell.a == 1 && st.cell.b == 1 && st.cell.c == 1 && st.cell.alpha == 90 &&
                                st.cell.beta == 90 && st.cell.gamma == 90))
    m.topology.unit_cell = CellDimensions{static_cast<float>(st.cell.a), static_cast<float>(st.cell.b), static_cast<float>(st.cell.c),
                                          static_cast<float>(st.cell.alpha), static_cast<float>(st.cell.beta),
                                          static_cast<float>(st.cell.gamma)};
  for (const gemmi::Chain& chain : model.chains) {
    const std::uint32_t c = index_of(chain.name, chain_index, m.chain_names);
    for (const gemmi::Residue& res : chain.residues) {
      // PDB assemblies name author chains; mmCIF ones name label_asym_ids (gemmi's "subchain").
      const std::uint32_t u = pdb ? index_of(chain.name, unit_index, m.unit_names)
                                  : index_of(res.subchain, unit_index, m.unit_names);
      const ResidueColorKey key = residue_color_key(res.name);
      for (const gemmi::Atom& atom : res.atoms) {
        const Vec3 p{static_cast<float>(atom.pos.x), static_cast<float>(atom.pos.y), static_cast<float>(atom.pos.z)};
        if (!is_finite(p))
          throw Error("atom " + std::to_string(atom.serial) + " (" + atom.name + " of " + res.name + " " +
                      res.seqid.str() + ", chain " + chain.name + "): coordinates are not finite numbers");
        m.positions.push_back(p);
        m.b_factors.push_back(atom.b_iso);
        m.occupancies.push_back(atom.occ);
        m.elements.push_back(static_cast<std::uint8_t>(element_from_symbol(atom.element.name())));
        m.chains.push_back(c);
        m.units.push_back(u);
        m.residue_keys.push_back(key);
        std::string type = atom.element.name();
        for (char& ch : type) ch = static_cast<char>(std::toupper(static_cast<unsigned char>(ch)));
        m.topology.add(atom.name, res.name, type, any_segment ? res.segment : chain.name, chain.name, res.seqid.num.value,
                       res.seqid.num.value);
      }
    }
  }

  if (pdb) return m;  // PDB assemblies come from scan_pdb
  for (const gemmi::Assembly& a : st.assemblies) {
    MoleculeAssembly& out = m.assemblies.emplace_back();
    out.name = a.name;
    for (const gemmi::Assembly::Gen& gen : a.generators) {
      AssemblyGenerator& g = out.generators.emplace_back();
      g.units = gen.subchains;
      for (const gemmi::Assembly::Operator& op : gen.operators) {
        AssemblyOperator& r = g.operators.emplace_back();
        for (int i = 0; i < 3; ++i) {
          for (int j = 0; j < 3; ++j) r[static_cast<std::size_t>(4 * i + j)] = op.transform.mat[i][j];
          r[static_cast<std::size_t>(4 * i + 3)] = op.transform.vec.at(i);
        }
        for (const double v : r)
          if (!std::isfinite(v))
            throw Error("assembly " + a.name + ", operator " + op.name + ": the matrix holds a non-finite number");
      }
    }
  }
  return m;
}

}  // namespace

// Two habits of gemmi 0.5.7's PDB parser that input must not reach:
// - it reads the distance of an SSBOND or LINK record (columns 74-78) whenever the record, line break
//   included, is longer than 73 characters, without checking that the five columns exist: a record of
//   74 to 77 characters makes it read up to three bytes past the end of its copy of the line (a heap
//   over-read; fast_float then compares the bytes after the line's end with "nan" and "inf");
// - it packs record names into an int by shifting (signed) chars: negative for bytes of 0x80 and up,
//   and shifting a negative int is undefined before C++20 (this file is C++17 under clang).
// So SSBOND and LINK records (gemmi knows them by their first four letters, any case: "SSBO", "LINK")
// are padded with blanks to 80 columns (gemmi then reads no distance), NUL bytes (which would end
// gemmi's copy of a line early, making a padded record short again) become blanks, and bytes above
// 0x7f, which the PDB format (ASCII) does not have, become '?'. A copy of the text is made only when it
// needs any of these.
bool pdb_text_for_gemmi(std::string_view text, std::string& fixed) {
  constexpr std::size_t kFull = 80;
  const auto short_record = [&](std::string_view line) {
    return (starts_with_ci(line, "SSBO") || starts_with_ci(line, "LINK")) && line.size() < kFull;
  };
  bool needed = std::any_of(text.begin(), text.end(), [](char c) { return c == '\0' || static_cast<unsigned char>(c) > 0x7f; });
  LineReader lines(text);
  std::string_view line;
  while (!needed && lines.next(line)) needed = short_record(line);
  if (!needed) return false;
  fixed.clear();
  fixed.reserve(text.size() + text.size() / 8);
  LineReader again(text);
  while (again.next(line)) {
    const std::size_t start = fixed.size();
    fixed += line;
    if (short_record(line)) fixed.append(kFull - line.size(), ' ');
    for (std::size_t i = start; i < fixed.size(); ++i)
      if (static_cast<unsigned char>(fixed[i]) > 0x7f) fixed[i] = '?';
      else if (fixed[i] == '\0') fixed[i] = ' ';
    fixed += '\n';
  }
  return true;
}

PackedMolecule read_molecule_gemmi(std::string_view text, MoleculeFormat format, const std::string& name) {
  std::vector<MoleculeAssembly> pdb_assemblies;
  if (format == MoleculeFormat::Pdb) pdb_assemblies = scan_pdb(text);
  gemmi::Structure st;
  try {
    st = parse_structure(text, format, name);
  } catch (const Error&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw;
  } catch (const std::exception& e) {
    // gemmi reports malformed input as std::runtime_error (PEGTL parse errors derive from it too).
    throw Error(std::string(format == MoleculeFormat::Pdb ? "PDB" : "mmCIF") + " parse error: " + e.what());
  }
  PackedMolecule m = pack(st, format);
  if (format == MoleculeFormat::Pdb) m.assemblies = std::move(pdb_assemblies);
  return m;
}

}  // namespace penumbra::io_detail
