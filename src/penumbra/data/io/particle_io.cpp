// Particle files: picks the reader by extension (after an optional .gz), reads the whole file into
// memory (inflating gzip with zlib), parses GROMACS .gro and XYZ here and PDB / mmCIF through gemmi
// (molecule_gemmi.cpp), all into the same packed per-atom arrays; then drops hydrogens if asked, gives
// each atom its radius and colour, and builds the chosen biological assembly by applying its operators
// to the packed coordinates in parallel. Every error is prefixed with the file name.
//
// Element of a .gro atom (the format has no element column), from its atom and residue names:
//   1. CHARMM ion residues: SOD Na, POT K, CLA Cl, CAL Ca, CES Cs, LIT Li, RUB Rb, BAR Ba, ZN2 Zn.
//   2. Leading digits of the atom name are skipped ("1HB" is H). When the letters of the atom name equal
//      the leading letters of the residue name and form an element symbol, that element (ions such as
//      NA/NA, CL/CL, CA/CA, CU/CU1, ZN/ZN2).
//   3. A two-letter name CL or BR followed by digits ("CL1", "BR") is chlorine or bromine.
//   4. Otherwise the element whose one-letter symbol is the first letter: H, C, N, O, S, P (so CA in a
//      protein is carbon, OW water oxygen, HW1 hydrogen, P8 phosphorus), F, I, K, B, V, W, U, Y. A first
//      letter that is no one-letter symbol (TIP4P's virtual site MW, LP lone pairs) is an unknown
//      element. Coarse-grained bead names are not recognised as such (MARTINI's BB reads as boron).
// The .gro and .xyz formats have no chains: every atom is in chain 0. XYZ has no residues (colour key 0).
//
// Topology for selections, as MDAnalysis's parsers give it: GRO residue number (columns 1-5, numbers
// after a wrap from 99999 to 0 raised by 100000), residue and atom name, segid SYSTEM, no chain id,
// type guessed from the atom name (guess_atom_type), unit cell from the box line; XYZ names from the
// first column, resid 1, segid SYSTEM, types guessed.
#include "penumbra/data/io/particle_io.h"

#include <zlib.h>
#ifdef __linux__
#include <sys/mman.h>
#endif

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <memory>
#include <optional>
#include <string_view>
#include <unordered_map>

#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/data/elements.h"
#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/molecule_gemmi.h"
#include "penumbra/data/io/text_fields.h"
#include "penumbra/data/selection/periodic_cell.h"

namespace penumbra {

namespace {

using io_detail::AssemblyOperator;
using io_detail::LineReader;
using io_detail::PackedMolecule;
using io_detail::ends_with_ci;
using io_detail::parse_number;
using io_detail::printable;
using io_detail::split_fields;
using io_detail::trim;
using io_detail::upper;

// A file inflated past this is refused rather than exhausting memory (a deflate bomb, or a mistake).
constexpr std::uint64_t kMaxTextBytes = 4ull << 30;
// More spheres than this (16 bytes each, plus colours) is refused before anything is allocated.
constexpr std::uint64_t kMaxSpheres = 1ull << 30;

// For messages: the text as found, cut short and with control bytes shown as '?'.
std::string quoted(std::string_view s) { return "'" + printable(s, 60) + (s.size() > 60 ? "…'" : "'"); }

// ------------------------------------------------------------------------------------------ reading

std::string read_plain(const std::string& path, std::uint64_t size) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot open the file");
  std::string text(static_cast<std::size_t>(size), '\0');
  in.read(text.data(), static_cast<std::streamsize>(size));
  if (static_cast<std::uint64_t>(in.gcount()) != size) throw Error("cannot read the file");
  return text;
}

struct GzCloser {
  void operator()(gzFile f) const { gzclose(f); }
};

std::string read_gzip(const std::string& path, std::uint64_t size) {
  {
    std::ifstream in(path, std::ios::binary);
    unsigned char magic[2] = {0, 0};
    in.read(reinterpret_cast<char*>(magic), 2);
    if (!in || magic[0] != 0x1f || magic[1] != 0x8b)
      throw Error("not gzip data (the name ends in .gz but the file does not start with the gzip magic 1f 8b)");
  }
  std::unique_ptr<gzFile_s, GzCloser> f(gzopen(path.c_str(), "rb"));
  if (!f) throw Error("cannot open the file");
  gzbuffer(f.get(), 1u << 17);
  std::string text;
  text.reserve(static_cast<std::size_t>(std::min<std::uint64_t>(size * 4, kMaxTextBytes)));
  constexpr unsigned kChunk = 1u << 20;
  for (;;) {
    const std::size_t old = text.size();
    if (old + kChunk > kMaxTextBytes) throw Error("gzip data inflates to more than " + io_detail::bytes_str(kMaxTextBytes));
    text.resize(old + kChunk);
    const int n = gzread(f.get(), text.data() + old, kChunk);
    if (n < 0) {
      int err = 0;
      throw Error(std::string("corrupt gzip data (") + gzerror(f.get(), &err) + ")");
    }
    text.resize(old + static_cast<std::size_t>(n));
    if (n == 0) break;
  }
  int err = Z_OK;
  const char* msg = gzerror(f.get(), &err);
  if (err != Z_OK) throw Error(std::string("corrupt gzip data (") + msg + ")");
  return text;
}

// ------------------------------------------------------------------------------------- text helpers

float finite_coordinate(std::string_view token, const char* axis, const LineReader& r) {
  double v = 0;
  if (!parse_number(token, v)) throw Error(r.where() + ": " + axis + " coordinate " + quoted(token) + " is not a number");
  if (!std::isfinite(v) || std::abs(v) > 1e30)
    throw Error(r.where() + ": " + axis + " coordinate " + quoted(token) + " is not a finite number");
  return static_cast<float>(v);
}
bool parse_count(std::string_view s, std::uint64_t& n) {
  s = trim(s);
  if (s.empty()) return false;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), n);
  return ec == std::errc() && end == s.data() + s.size();
}
void push_atom(PackedMolecule& m, Vec3 p, int element, ResidueColorKey key) {
  m.positions.push_back(p);
  m.elements.push_back(static_cast<std::uint8_t>(element));
  m.chains.push_back(0);
  m.units.push_back(0);
  m.residue_keys.push_back(key);
}
void single_chain(PackedMolecule& m) {
  m.chain_names = {""};
  m.unit_names = {""};
}

// ---------------------------------------------------------------------------------------------- gro

std::string leading_letters(std::string_view s) {
  std::size_t n = 0;
  while (n < s.size() && std::isalpha(static_cast<unsigned char>(s[n]))) ++n;
  return upper(s.substr(0, n));
}

// The heuristic in the header comment.
int gro_element(std::string_view atom_name, std::string_view residue_name) {
  static const std::unordered_map<std::string, int> kCharmmIons{
      {"SOD", 11}, {"POT", 19}, {"CLA", 17}, {"CAL", 20}, {"CES", 55}, {"LIT", 3}, {"RUB", 37}, {"BAR", 56}, {"ZN2", 30}};
  const std::string res = upper(residue_name);
  if (const auto it = kCharmmIons.find(res); it != kCharmmIons.end()) return it->second;
  while (!atom_name.empty() && std::isdigit(static_cast<unsigned char>(atom_name.front()))) atom_name.remove_prefix(1);
  const std::string letters = leading_letters(atom_name);
  if (letters.empty()) return kUnknownElement;
  if (letters == leading_letters(residue_name)) {
    const int z = element_from_symbol(letters);
    if (z != kUnknownElement) return z;
  }
  if (letters == "CL") return element_from_symbol("Cl");
  if (letters == "BR") return element_from_symbol("Br");
  return element_from_symbol(letters.substr(0, 1));
}

bool parse_integer(std::string_view s, std::int64_t& n) {
  s = trim(s);
  if (!s.empty() && s.front() == '+') s.remove_prefix(1);
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), n);
  return !s.empty() && ec == std::errc() && end == s.data() + s.size();
}

// GRO residue numbers have five columns: after 99999 comes 0. As MDAnalysis's GRO parser, every run
// of zeros not at the start raises the numbers from it on by 100000.
void unwrap_gro_residue_numbers(AtomTopology& t) {
  for (std::size_t i = 1; i < t.resids.size(); ++i)
    if (t.resids[i] == 0 && t.resids[i - 1] != 0)
      for (std::size_t j = i; j < t.resids.size(); ++j) t.resids[j] += 100000;
  t.resnums = t.resids;
}

// The box line's vectors (nm: v1x v2y v3z, then v1y v1z v2x v2z v3x v3y) as lengths (Å) and angles;
// none when it is all zeros.
std::optional<CellDimensions> gro_cell_dimensions(const std::vector<std::string_view>& box) {
  double v[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
  for (std::size_t i = 0; i < box.size(); ++i) parse_number(box[i], v[i]);
  const Vec3 a{static_cast<float>(v[0]), static_cast<float>(v[3]), static_cast<float>(v[4])},
      b{static_cast<float>(v[5]), static_cast<float>(v[1]), static_cast<float>(v[6])},
      c{static_cast<float>(v[7]), static_cast<float>(v[8]), static_cast<float>(v[2])};
  const float la = length(a), lb = length(b), lc = length(c);
  if (la == 0 || lb == 0 || lc == 0) return std::nullopt;
  const auto angle = [](Vec3 x, Vec3 y) {
    return static_cast<float>(std::acos(std::clamp(dot(x, y) / (length(x) * length(y)), -1.0f, 1.0f)) * 180.0 / 3.14159265358979323846);
  };
  return CellDimensions{la * 10, lb * 10, lc * 10, angle(b, c), angle(a, c), angle(a, b)};
}

// GROMACS .gro (manual, "File formats: gro"): title; atom count; per atom "%5d%-5s%5s%5d" then x y z
// (nm) and optionally velocities, in fields of p + 5 columns for p decimals (%8.3f normally); then the box line (3 or 9 numbers). Later frames are ignored.
PackedMolecule read_gro(std::string_view text) {
  LineReader r(text);
  std::string_view line;
  if (!r.next(line)) throw Error("empty file (expected GROMACS .gro: title, atom count, atom lines, box)");
  if (!r.next(line)) throw Error("line 2: missing the atom count (the file ends after the title)");
  std::uint64_t count = 0;
  if (!parse_count(line, count)) throw Error("line 2: atom count " + quoted(line) + " is not a non-negative integer");
  if (count == 0) throw Error("line 2: the atom count is 0 (no atoms)");

  PackedMolecule m;
  single_chain(m);
  m.reserve(static_cast<std::size_t>(std::min<std::uint64_t>(count, text.size() / 44 + 1)));
  std::size_t width = 0;  // of a coordinate field, from the first atom line
  for (std::uint64_t i = 0; i < count; ++i) {
    if (!r.next(line))
      throw Error("line " + std::to_string(r.line_no() + 1) + ": the file ends after " + std::to_string(i) +
                  " atom lines, but line 2 says " + std::to_string(count) + " atoms");
    if (width == 0) {
      // GROMACS writes x y z as %(p+5).pf: the digits after the first decimal point give the width.
      const std::size_t dot = line.size() > 20 ? line.find('.', 20) : std::string_view::npos;
      std::size_t decimals = 3;
      if (dot != std::string_view::npos) {
        decimals = 0;
        while (dot + 1 + decimals < line.size() && std::isdigit(static_cast<unsigned char>(line[dot + 1 + decimals]))) ++decimals;
      }
      width = decimals + 5;
      if (decimals < 1 || decimals > 18)
        throw Error(r.where() + ": cannot tell the coordinate field width (" + std::to_string(decimals) +
                    " digits after the first decimal point; GROMACS writes x y z as %8.3f)");
    }
    if (line.size() < 20 + 3 * width)
      throw Error(r.where() + ": atom line is truncated (" + std::to_string(line.size()) + " columns; expected " +
                  "residue and atom in columns 1-20, then x y z in " + std::to_string(width) + "-column fields)");
    const std::string_view residue = trim(line.substr(5, 5)), atom = trim(line.substr(10, 5));
    std::int64_t resid = 0;
    if (!parse_integer(line.substr(0, 5), resid))
      throw Error(r.where() + ": residue number (columns 1-5) " + quoted(line.substr(0, 5)) + " is not an integer");
    m.topology.add(atom, residue, guess_atom_type(atom), "SYSTEM", "", static_cast<std::int32_t>(resid),
                   static_cast<std::int32_t>(resid));
    const Vec3 p{finite_coordinate(line.substr(20, width), "x", r), finite_coordinate(line.substr(20 + width, width), "y", r),
                 finite_coordinate(line.substr(20 + 2 * width, width), "z", r)};
    push_atom(m, p * 10.0f, gro_element(atom, residue), residue_color_key(residue));  // nm → Å
  }
  if (!r.next(line))
    throw Error("line " + std::to_string(r.line_no() + 1) + ": missing the box line after the " + std::to_string(count) + " atoms");
  const auto box = split_fields(line);
  double v = 0;
  if ((box.size() != 3 && box.size() != 9) ||
      !std::all_of(box.begin(), box.end(), [&](std::string_view t) { return parse_number(t, v); }))
    throw Error(r.where() + ": expected the box line (3 or 9 numbers) after " + std::to_string(count) +
                " atoms, found " + quoted(line) + "; is the atom count on line 2 right?");
  unwrap_gro_residue_numbers(m.topology);
  m.topology.unit_cell = gro_cell_dimensions(box);
  return m;
}

// ---------------------------------------------------------------------------------------------- xyz

// XYZ: atom count; comment; per atom "symbol x y z" (Å; extra columns ignored; the symbol may be an
// atomic number, or carry a label after it, e.g. "C1"). Only the first frame is read, but what follows
// it must be the next frame's count line (or nothing), so a count that is too small is caught.
PackedMolecule read_xyz(std::string_view text) {
  LineReader r(text);
  std::string_view line;
  if (!r.next(line)) throw Error("empty file (expected XYZ: atom count, comment, then 'symbol x y z' per atom)");
  std::uint64_t count = 0;
  if (!parse_count(line, count)) throw Error("line 1: atom count " + quoted(line) + " is not a non-negative integer");
  if (count == 0) throw Error("line 1: the atom count is 0 (no atoms)");
  if (!r.next(line)) throw Error("line 2: missing the comment line (the file ends after the atom count)");

  PackedMolecule m;
  single_chain(m);
  m.reserve(static_cast<std::size_t>(std::min<std::uint64_t>(count, text.size() / 8 + 1)));
  for (std::uint64_t i = 0; i < count; ++i) {
    if (!r.next(line))
      throw Error("line " + std::to_string(r.line_no() + 1) + ": the file ends after " + std::to_string(i) +
                  " atom lines, but line 1 says " + std::to_string(count) + " atoms");
    const auto tokens = split_fields(line);
    if (tokens.size() < 4) throw Error(r.where() + ": expected 'symbol x y z', found " + quoted(line));
    int z = kUnknownElement;
    std::uint64_t number = 0;
    if (parse_count(tokens[0], number))
      z = number >= 1 && number <= kMaxElement ? static_cast<int>(number) : kUnknownElement;
    else
      z = element_from_symbol(leading_letters(tokens[0]));
    push_atom(m, {finite_coordinate(tokens[1], "x", r), finite_coordinate(tokens[2], "y", r), finite_coordinate(tokens[3], "z", r)},
              z, kOtherResidue);
    m.topology.add(tokens[0], "", guess_atom_type(tokens[0]), "SYSTEM", "", 1, 1);
  }
  while (r.next(line)) {
    if (trim(line).empty()) continue;
    std::uint64_t next_count = 0;
    if (!parse_count(line, next_count))
      throw Error(r.where() + ": expected the end of the file or the next frame's atom count after " +
                  std::to_string(count) + " atoms, found " + quoted(line) + "; is the atom count on line 1 right?");
    break;
  }
  return m;
}

// ---------------------------------------------------------------------------------------- assembly

// Reserves n elements and, on Linux, asks for transparent huge pages over them before anything touches
// them: filling 16 M spheres (260 MB) otherwise spends most of its time in 4 KB page faults.
template <class T>
void reserve_huge(std::vector<T>& v, std::size_t n) {
  v.reserve(n);
#ifdef __linux__
  constexpr std::uintptr_t kHuge = std::uintptr_t{2} << 20;
  const auto begin = reinterpret_cast<std::uintptr_t>(v.data());
  const std::uintptr_t lo = (begin + kHuge - 1) & ~(kHuge - 1), hi = (begin + n * sizeof(T)) & ~(kHuge - 1);
  if (hi > lo) madvise(reinterpret_cast<void*>(lo), hi - lo, MADV_HUGEPAGE);  // advice only: failure is harmless
#endif
}

// The per-atom values of ParticleColoring::Scalar, or Error when the format has none.
const std::vector<float>& scalar_values(const PackedMolecule& m, ParticleScalar which, std::vector<float>& index) {
  if (which == ParticleScalar::Index) {
    index.resize(m.size());
    for (std::size_t i = 0; i < m.size(); ++i) index[i] = static_cast<float>(i);
    return index;
  }
  const std::vector<float>& v = which == ParticleScalar::BFactor ? m.b_factors : m.occupancies;
  if (v.size() != m.size())
    throw Error(std::string("color_by scalar: the file has no ") + (which == ParticleScalar::BFactor ? "B-factors" : "occupancies") +
                " (only PDB and mmCIF do; \"index\" works for every format)");
  return v;
}

// ParaView's default diverging map, "Cool to Warm" (Moreland 2009), over the data range.
TransferFunction cool_to_warm(float lo, float hi) {
  auto c = [](float r, float g, float b) { return Rgb{srgb_to_linear(r), srgb_to_linear(g), srgb_to_linear(b)}; };
  return TransferFunction({{lo, c(0.230f, 0.299f, 0.754f), 1}, {0.5f * (lo + hi), c(0.865f, 0.865f, 0.865f), 1},
                           {hi, c(0.706f, 0.016f, 0.150f), 1}});
}

std::uint32_t color_of(const PackedMolecule& m, std::size_t i, const ParticleLoadOptions& o) {
  switch (o.coloring) {
    case ParticleColoring::Scalar: break;  // coloured by build_particles, which knows the range
    case ParticleColoring::Element: return pack_rgba8(element_color(m.elements[i]));
    case ParticleColoring::Chain: return pack_rgba8(chain_color(m.chains[i]));
    case ParticleColoring::Residue: return pack_rgba8(residue_color(m.residue_keys[i]));
    case ParticleColoring::Uniform: break;
  }
  return pack_rgba8(o.uniform_color);
}

// Spheres of the generators of assembly `n` (1-based) applied to `base`, which holds the kept atoms
// `kept` of `m`. Output order: generator, operator, atom. Sized exactly before it is filled.
ParticleSet expand_assembly(const PackedMolecule& m, const std::vector<std::uint32_t>& kept, const ParticleSet& base,
                            int n, std::uint64_t max_spheres, int& operators) {
  const int count = static_cast<int>(m.assemblies.size());
  if (count == 0) throw Error("assembly " + std::to_string(n) + " was asked for, but the file lists no biological assemblies");
  if (n < 1 || n > count)
    throw Error("assembly " + std::to_string(n) + " does not exist: the file lists " + std::to_string(count) +
                (count == 1 ? " assembly (1)" : " assemblies (1-" + std::to_string(count) + ")"));
  const io_detail::MoleculeAssembly& assembly = m.assemblies[static_cast<std::size_t>(n - 1)];

  std::unordered_map<std::string, std::uint32_t> unit_index;
  for (std::size_t u = 0; u < m.unit_names.size(); ++u) unit_index.emplace(m.unit_names[u], static_cast<std::uint32_t>(u));

  struct Job {
    const std::vector<std::uint32_t>* atoms;  // indices into base
    const AssemblyOperator* op;
    std::size_t offset;
  };
  std::vector<std::vector<std::uint32_t>> selections(assembly.generators.size());
  std::vector<Job> jobs;
  std::uint64_t total = 0;
  operators = 0;
  for (std::size_t g = 0; g < assembly.generators.size(); ++g) {
    const io_detail::AssemblyGenerator& gen = assembly.generators[g];
    std::vector<char> selected(m.unit_names.size(), 0);
    for (const std::string& name : gen.units)
      if (const auto it = unit_index.find(name); it != unit_index.end()) selected[it->second] = 1;
    for (std::uint32_t k = 0; k < kept.size(); ++k)
      if (selected[m.units[kept[k]]]) selections[g].push_back(k);
    for (const AssemblyOperator& op : gen.operators) {
      jobs.push_back({&selections[g], &op, static_cast<std::size_t>(total)});
      total += selections[g].size();
      ++operators;
      if (total > max_spheres)
        throw Error("assembly " + std::to_string(n) + " would have more than " + std::to_string(max_spheres) +
                    " spheres (" + std::to_string(kept.size()) + " atoms, " + std::to_string(operators) + "+ operators)");
    }
  }
  if (total == 0) throw Error("assembly " + std::to_string(n) + " selects no atoms (its generators name no chain present)");

  ParticleSet out;
  reserve_huge(out.spheres, static_cast<std::size_t>(total));
  reserve_huge(out.colors, static_cast<std::size_t>(total));
  out.spheres.resize(static_cast<std::size_t>(total));
  out.colors.resize(static_cast<std::size_t>(total));
  if (!base.atoms.empty()) out.atoms.resize(static_cast<std::size_t>(total));
  std::vector<char> overflow(jobs.size(), 0);  // per job: a transformed centre was not finite
  parallel_for(jobs.size(), [&](std::size_t begin, std::size_t end) {
    for (std::size_t j = begin; j < end; ++j) {
      const Job& job = jobs[j];
      const AssemblyOperator& a = *job.op;
      Sphere* dst = out.spheres.data() + job.offset;
      std::uint32_t* dst_color = out.colors.data() + job.offset;
      std::uint32_t* dst_atom = out.atoms.empty() ? nullptr : out.atoms.data() + job.offset;
      for (const std::uint32_t k : *job.atoms) {
        const Sphere& s = base.spheres[k];
        const double x = s.center.x, y = s.center.y, z = s.center.z;
        dst->center = Vec3{static_cast<float>(a[0] * x + a[1] * y + a[2] * z + a[3]),
                           static_cast<float>(a[4] * x + a[5] * y + a[6] * z + a[7]),
                           static_cast<float>(a[8] * x + a[9] * y + a[10] * z + a[11])};
        dst->radius = s.radius;
        if (!is_finite(dst->center)) overflow[j] = 1;
        ++dst;
        *dst_color++ = base.colors[k];
        if (dst_atom) *dst_atom++ = base.atoms[k];
      }
    }
  });
  if (std::find(overflow.begin(), overflow.end(), 1) != overflow.end())
    throw Error("assembly " + std::to_string(n) + ": an operator moves atoms beyond the float range");
  out.color_key = base.color_key;  // an assembly's copies count as often as they are drawn; the crystal's cell is not the assembly's
  recount(out.color_key, out.colors);
  return out;
}

// What the colours of the kept atoms `kept` (colours `colors`) stand for, by the names of `coloring`.
ColorKey color_key_of(const PackedMolecule& m, const std::vector<std::uint32_t>& kept, const std::vector<std::uint32_t>& colors,
                      ParticleColoring coloring) {
  const std::string by = to_string(coloring);
  switch (coloring) {
    case ParticleColoring::Element:
      return categorical_color_key(by, colors, [&](std::size_t k) { return m.elements[kept[k]]; },
                                   [](std::uint32_t z) { return std::string(element_symbol(static_cast<int>(z))); });
    case ParticleColoring::Chain:
      return categorical_color_key(by, colors, [&](std::size_t k) { return m.chains[kept[k]]; },
                                   [&](std::uint32_t c) { return m.chain_names[c]; });
    case ParticleColoring::Residue:  // by the residue names (every non-standard one shares the grey)
      return categorical_color_key(by, colors, [&](std::size_t k) { return m.topology.resnames[kept[k]]; },
                                   [&](std::uint32_t r) { return m.topology.strings[r]; });
    case ParticleColoring::Uniform:
    case ParticleColoring::Scalar:
      break;
  }
  return categorical_color_key(by, colors, [](std::size_t) { return 0u; }, [](std::uint32_t) { return std::string("all atoms"); });
}

ParticleSet build_from_molecule(const PackedMolecule& m, const ParticleLoadOptions& o, ParticleFileInfo& info) {
  if (!std::isfinite(o.radius_scale) || o.radius_scale <= 0)
    throw Error("radius_scale must be a positive finite number, got " + num(o.radius_scale));
  info.atoms_in_file = m.size();
  info.unknown_elements = static_cast<std::size_t>(std::count(m.elements.begin(), m.elements.end(), kUnknownElement));
  info.operators = 0;

  std::vector<std::uint32_t> selected;
  if (o.selection) {
    selected = o.selection->evaluate(m.topology, m.positions, m.topology.unit_cell);
  } else {
    selected.resize(m.size());
    for (std::size_t i = 0; i < m.size(); ++i) selected[i] = static_cast<std::uint32_t>(i);
  }
  info.selected_atoms = selected.size();
  std::vector<std::uint32_t> kept;
  kept.reserve(selected.size());
  for (const std::uint32_t i : selected)
    if (o.hydrogens || m.elements[i] != kHydrogen) kept.push_back(i);
  if (kept.empty() && !o.selection) throw Error("no atoms left after dropping hydrogens (the file has only H/D atoms)");

  ParticleSet base;
  base.spheres.resize(kept.size());
  base.colors.resize(kept.size());
  for (std::size_t k = 0; k < kept.size(); ++k) {
    const std::size_t i = kept[k];
    base.spheres[k] = Sphere{m.positions[i], element_vdw_radius(m.elements[i]) * o.radius_scale};
    base.colors[k] = color_of(m, i, o);
  }
  if (o.coloring == ParticleColoring::Scalar) {
    std::vector<float> index;
    const std::vector<float>& v = scalar_values(m, o.scalar, index);
    float lo = kInfinity, hi = -kInfinity;
    for (const std::uint32_t i : kept) {
      lo = std::min(lo, v[i]);
      hi = std::max(hi, v[i]);
    }
    if (!(std::isfinite(lo) && std::isfinite(hi))) throw Error("color_by scalar: the values are not finite numbers");
    info.scalar_min = lo;
    info.scalar_max = hi;
    const TransferFunction map = o.color_map ? o.color_map(lo, hi) : cool_to_warm(lo, hi);
    for (std::size_t k = 0; k < kept.size(); ++k) base.colors[k] = pack_rgba8(map.evaluate(v[kept[k]]).rgb);
    base.color_key = scalar_color_key(to_string(o.scalar), lo, hi, map);
  } else {
    base.color_key = color_key_of(m, kept, base.colors, o.coloring);
  }
  if (const std::optional<PeriodicCell> cell = periodic_cell(m.topology.unit_cell)) base.box = PeriodicBox{{}, cell->a, cell->b, cell->c};
  if (o.selection) base.atoms = kept;
  if (o.assembly == 0 || kept.empty()) return base;
  return expand_assembly(m, kept, base, o.assembly, std::min(o.max_spheres, kMaxSpheres), info.operators);
}

}  // namespace

std::string particle_file_format(const std::string& path) {
  std::string_view name = path;
  if (ends_with_ci(name, ".gz")) name.remove_suffix(3);
  if (ends_with_ci(name, ".pdb") || ends_with_ci(name, ".ent")) return "pdb";
  if (ends_with_ci(name, ".cif") || ends_with_ci(name, ".mmcif")) return "mmcif";
  if (ends_with_ci(name, ".gro")) return "gro";
  if (ends_with_ci(name, ".xyz")) return "xyz";
  return "";
}

struct ParticleFile {
  std::string path, format;
  PackedMolecule molecule;
};

std::shared_ptr<const ParticleFile> read_particle_file(const std::string& path) {
  return with_context(path, [&] {
    const bool gz = ends_with_ci(path, ".gz");
    auto file = std::make_shared<ParticleFile>();
    file->path = path;
    file->format = particle_file_format(path);
    if (file->format.empty())
      throw Error("unknown particle file extension (supported: .pdb, .ent, .cif, .mmcif, .gro, .xyz, each "
                  "optionally gzip-compressed with .gz)");

    const std::uint64_t size = io_detail::regular_file_size(path);
    if (size == 0) throw Error("empty file");
    const std::string text = gz ? read_gzip(path, size) : read_plain(path, size);
    if (trim(text).empty()) throw Error(gz ? "empty file (after decompression)" : "empty file (only blanks)");

    const std::string& format = file->format;
    file->molecule =
        format == "gro"   ? read_gro(text)
        : format == "xyz" ? read_xyz(text)
                          : io_detail::read_molecule_gemmi(
                                text, format == "pdb" ? io_detail::MoleculeFormat::Pdb : io_detail::MoleculeFormat::Mmcif, path);
    return std::shared_ptr<const ParticleFile>(std::move(file));
  });
}

const AtomTopology& topology_of(const ParticleFile& file) { return file.molecule.topology; }
const std::vector<Vec3>& positions_of(const ParticleFile& file) { return file.molecule.positions; }

ParticleSet build_particles(const ParticleFile& file, const ParticleLoadOptions& options, ParticleFileInfo* info) {
  return with_context(file.path, [&] {
    ParticleFileInfo local;
    ParticleFileInfo& out_info = info ? *info : local;
    out_info = ParticleFileInfo{};
    out_info.format = file.format;
    return build_from_molecule(file.molecule, options, out_info);
  });
}

ParticleSet load_particles(const std::string& path, const ParticleLoadOptions& options, ParticleFileInfo* info) {
  return build_particles(*read_particle_file(path), options, info);
}

std::string to_string(ParticleColoring c) {
  switch (c) {
    case ParticleColoring::Element: return "element";
    case ParticleColoring::Chain: return "chain";
    case ParticleColoring::Residue: return "residue";
    case ParticleColoring::Uniform: return "uniform";
    case ParticleColoring::Scalar: return "scalar";
  }
  return "element";
}

ParticleColoring particle_coloring_from_string(const std::string& s) {
  for (ParticleColoring c : {ParticleColoring::Element, ParticleColoring::Chain, ParticleColoring::Residue,
                             ParticleColoring::Uniform, ParticleColoring::Scalar})
    if (s == to_string(c)) return c;
  throw Error("unknown particle coloring '" + s + "' (expected element, chain, residue, uniform or scalar)");
}

std::string to_string(ParticleScalar s) {
  switch (s) {
    case ParticleScalar::BFactor: return "b_factor";
    case ParticleScalar::Occupancy: return "occupancy";
    case ParticleScalar::Index: return "index";
  }
  return "";
}

ParticleScalar particle_scalar_from_string(const std::string& s) {
  if (s == "b_factor") return ParticleScalar::BFactor;
  if (s == "occupancy") return ParticleScalar::Occupancy;
  if (s == "index") return ParticleScalar::Index;
  throw Error("unknown particle scalar '" + s + "' (expected b_factor, occupancy or index)");
}

}  // namespace penumbra
