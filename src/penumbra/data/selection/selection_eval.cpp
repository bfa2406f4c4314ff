// Evaluating a parsed selection: every node gives a mask over all atoms, as MDAnalysis applies every
// part of a selection to the whole universe (`around` inside an `and` still looks at every atom).
// String keywords test each distinct string of the topology once, not each atom. Residue-name lists
// are MDAnalysis 2.4's (ProteinSelection.prot_res, NucleicSelection.nucl_res, backbone names N CA C O);
// `water` is VMD's residue-name list.
#include <algorithm>
#include <unordered_set>

#include "penumbra/core/error.h"
#include "penumbra/data/selection/name_pattern.h"
#include "penumbra/data/selection/neighbor_grid.h"
#include "penumbra/data/selection/periodic_cell.h"
#include "penumbra/data/selection/selection.h"

namespace penumbra {
namespace {

using Kind = SelectionNode::Kind;
using AtomMask = std::vector<std::uint8_t>;

const std::unordered_set<std::string>& protein_residues() {
  static const std::unordered_set<std::string> names{
      "ALA", "ARG", "ASN", "ASP", "CYS", "GLN", "GLU", "GLY", "HSD", "HSE", "HSP", "ILE", "LEU", "LYS", "MET", "PHE",
      "PRO", "SER", "THR", "TRP", "TYR", "VAL", "ALAD", "HIS", "MSE", "ARGN", "ASPH", "CYS2", "CYSH", "QLN", "PGLU",
      "GLUH", "HIS1", "HISD", "HISE", "HISH", "LYSH", "ASN1", "CYS1", "HISA", "HISB", "HIS2", "HID", "HIE", "HIP",
      "ORN", "DAB", "LYN", "HYP", "CYM", "CYX", "ASH", "GLH", "ACE", "NME", "NALA", "NGLY", "NSER", "NTHR", "NLEU",
      "NILE", "NVAL", "NASN", "NGLN", "NARG", "NHID", "NHIE", "NHIP", "NTRP", "NPHE", "NTYR", "NGLU", "NASP", "NLYS",
      "NPRO", "NCYS", "NCYX", "NMET", "CALA", "CGLY", "CSER", "CTHR", "CLEU", "CILE", "CVAL", "CASF", "CASN", "CGLN",
      "CARG", "CHID", "CHIE", "CHIP", "CTRP", "CPHE", "CTYR", "CGLU", "CASP", "CLYS", "CPRO", "CCYS", "CCYX", "CMET",
      "CME", "ASF"};
  return names;
}
const std::unordered_set<std::string>& nucleic_residues() {
  static const std::unordered_set<std::string> names{
      "ADE", "URA", "CYT", "GUA", "THY", "DA", "DC", "DG", "DT", "RA", "RU", "RG", "RC", "A", "T", "U", "C", "G",
      "DA5", "DC5", "DG5", "DT5", "DA3", "DC3", "DG3", "DT3", "RA5", "RU5", "RG5", "RC5", "RA3", "RU3", "RG3", "RC3"};
  return names;
}
const std::unordered_set<std::string>& water_residues() {  // VMD's `water`
  static const std::unordered_set<std::string> names{"H2O", "HH0", "OHH", "HOH", "OH2", "SOL", "WAT", "TIP", "TIP2", "TIP3", "TIP4"};
  return names;
}

class SelectionEvaluator {
public:
  SelectionEvaluator(const AtomTopology& t, const std::vector<Vec3>& positions, const std::optional<CellDimensions>& cell)
      : t_(t), positions_(positions), cell_(periodic_cell(cell)) {}

  AtomMask eval(const SelectionNode& n) const {
    const std::size_t count = t_.size();
    switch (n.kind) {
      case Kind::All: return AtomMask(count, 1);
      case Kind::None: return AtomMask(count, 0);
      case Kind::Protein: return by_string(t_.resnames, [](const std::string& s) { return protein_residues().count(s) > 0; });
      case Kind::Nucleic: return by_string(t_.resnames, [](const std::string& s) { return nucleic_residues().count(s) > 0; });
      case Kind::Water: return by_string(t_.resnames, [](const std::string& s) { return water_residues().count(s) > 0; });
      case Kind::Backbone: {
        AtomMask m = by_string(t_.resnames, [](const std::string& s) { return protein_residues().count(s) > 0; });
        const AtomMask names = by_string(t_.names, [](const std::string& s) { return s == "N" || s == "CA" || s == "C" || s == "O"; });
        for (std::size_t i = 0; i < count; ++i) m[i] &= names[i];
        return m;
      }
      case Kind::Name: return by_patterns(t_.names, n.patterns);
      case Kind::Type: return by_patterns(t_.types, n.patterns);
      case Kind::Resname: return by_patterns(t_.resnames, n.patterns);
      case Kind::Segid: return by_patterns(t_.segids, n.patterns);
      case Kind::ChainId: return by_patterns(t_.chain_ids, n.patterns);
      case Kind::Resid: return by_ranges(n.ranges, [&](std::size_t i) { return std::int64_t{t_.resids[i]}; });
      case Kind::Resnum: return by_ranges(n.ranges, [&](std::size_t i) { return std::int64_t{t_.resnums[i]}; });
      case Kind::Index: return by_ranges(n.ranges, [](std::size_t i) { return static_cast<std::int64_t>(i); });
      case Kind::Bynum: return by_ranges(n.ranges, [](std::size_t i) { return static_cast<std::int64_t>(i) + 1; });
      case Kind::Not: {
        AtomMask m = eval(*n.children[0]);
        for (auto& v : m) v = !v;
        return m;
      }
      case Kind::And:
      case Kind::Or: {
        AtomMask a = eval(*n.children[0]);
        const AtomMask b = eval(*n.children[1]);
        for (std::size_t i = 0; i < count; ++i) a[i] = n.kind == Kind::And ? (a[i] & b[i]) : (a[i] | b[i]);
        return a;
      }
      case Kind::Around:
      case Kind::Within: return near(n);
      case Kind::Sphzone: return sphere_zone(n);
      case Kind::SameAs: return same_as(n);
    }
    return AtomMask(count, 0);
  }

private:
  const AtomTopology& t_;
  const std::vector<Vec3>& positions_;
  std::optional<PeriodicCell> cell_;

  template <class Test>
  AtomMask by_string(const std::vector<std::uint32_t>& field, Test test) const {
    std::vector<std::uint8_t> passes(t_.strings.size());
    for (std::uint32_t s = 0; s < t_.strings.size(); ++s) passes[s] = test(t_.strings[s]) ? 1 : 0;
    AtomMask m(field.size());
    for (std::size_t i = 0; i < field.size(); ++i) m[i] = passes[field[i]];
    return m;
  }
  AtomMask by_patterns(const std::vector<std::uint32_t>& field, const std::vector<std::string>& patterns) const {
    return by_string(field, [&](const std::string& s) {
      return std::any_of(patterns.begin(), patterns.end(), [&](const std::string& p) { return matches_name_pattern(s, p); });
    });
  }
  template <class Value>
  AtomMask by_ranges(const std::vector<std::pair<std::int64_t, std::int64_t>>& ranges, Value value) const {
    AtomMask m(t_.size());
    for (std::size_t i = 0; i < m.size(); ++i) {
      const std::int64_t v = value(i);
      m[i] = std::any_of(ranges.begin(), ranges.end(), [&](const auto& r) { return r.first <= v && v <= r.second; }) ? 1 : 0;
    }
    return m;
  }

  // around: atoms outside the selection within the distance of it; within (VMD): the selection too.
  AtomMask near(const SelectionNode& n) const {
    const AtomMask reference = eval(*n.children[0]);
    AtomMask test(reference.size());
    for (std::size_t i = 0; i < reference.size(); ++i) test[i] = !reference[i];
    AtomMask m = points_near(positions_, reference, test, static_cast<float>(n.distance), cell_);
    if (n.kind == Kind::Within)
      for (std::size_t i = 0; i < m.size(); ++i) m[i] |= reference[i];
    return m;
  }

  // sphzone: atoms within the distance of the selection's centre of geometry (not made whole across
  // the box, as MDAnalysis's center_of_geometry()).
  AtomMask sphere_zone(const SelectionNode& n) const {
    const AtomMask reference = eval(*n.children[0]);
    double sum[3] = {0, 0, 0};
    std::size_t count = 0;
    for (std::size_t i = 0; i < reference.size(); ++i)
      if (reference[i]) {
        for (int a = 0; a < 3; ++a) sum[a] += positions_[i][a];
        ++count;
      }
    AtomMask m(reference.size(), 0);
    if (count == 0) return m;
    const double n_ref = static_cast<double>(count);
    const Vec3 centre{static_cast<float>(sum[0] / n_ref), static_cast<float>(sum[1] / n_ref), static_cast<float>(sum[2] / n_ref)};
    const float r2 = static_cast<float>(n.distance * n.distance);
    for (std::size_t i = 0; i < m.size(); ++i) {
      const Vec3 d = positions_[i] - centre;
      m[i] = (cell_ ? cell_->minimum_image_length2(d) : dot(d, d)) <= r2 ? 1 : 0;
    }
    return m;
  }

  AtomMask same_as(const SelectionNode& n) const {
    const AtomMask inner = eval(*n.children[0]);
    const auto by_field = [&](const auto& field) {
      using T = typename std::decay_t<decltype(field)>::value_type;
      std::unordered_set<T> values;
      for (std::size_t i = 0; i < inner.size(); ++i)
        if (inner[i]) values.insert(field[i]);
      AtomMask m(inner.size());
      for (std::size_t i = 0; i < m.size(); ++i) m[i] = values.count(field[i]) ? 1 : 0;
      return m;
    };
    const std::string& p = n.property;
    if (p == "residue") return by_field(t_.residues);
    if (p == "name") return by_field(t_.names);
    if (p == "type") return by_field(t_.types);
    if (p == "resname") return by_field(t_.resnames);
    if (p == "segid") return by_field(t_.segids);
    if (p == "resid") return by_field(t_.resids);
    return by_field(t_.resnums);
  }
};

}  // namespace

std::vector<std::uint32_t> AtomSelection::evaluate(const AtomTopology& topology, const std::vector<Vec3>& positions,
                                                   const std::optional<CellDimensions>& cell) const {
  if (positions.size() != topology.size())
    throw Error("selection '" + text_ + "': " + std::to_string(positions.size()) + " positions for " +
                std::to_string(topology.size()) + " atoms");
  const AtomMask m = SelectionEvaluator(topology, positions, cell).eval(*root_);
  std::vector<std::uint32_t> selected;
  for (std::size_t i = 0; i < m.size(); ++i)
    if (m[i]) selected.push_back(static_cast<std::uint32_t>(i));
  return selected;
}

}  // namespace penumbra
