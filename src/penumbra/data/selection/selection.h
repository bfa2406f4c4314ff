// Atom selections in MDAnalysis's selection language (MDAnalysis 2.4 `select_atoms`, with its
// precedence, wildcards, ranges and periodic distances), plus VMD's `water` and `within D of SEL` and
// `none`. docs/selections.md has the grammar. A selection is parsed once (parse_selection) and
// evaluated against an AtomTopology and the atoms' positions; the result is the selected atom indices,
// ascending.
#pragma once

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/data/selection/atom_topology.h"

namespace penumbra {

struct SelectionNode {
  enum class Kind {
    All, None, Protein, Backbone, Nucleic, Water,       // keywords without values
    Name, Type, Resname, Segid, ChainId,                // string values with wildcards
    Resid, Resnum, Index, Bynum,                        // integer values and ranges
    Around, Sphzone,                                     // distance to a selection (`within` is Around with the reference kept)
    Within, SameAs, Not, And, Or
  };
  Kind kind = Kind::All;
  std::vector<std::string> patterns;                           // Name … ChainId
  std::vector<std::pair<std::int64_t, std::int64_t>> ranges;   // Resid … Bynum: inclusive [lo, hi]
  double distance = 0;                                         // Around, Sphzone, Within (Å)
  std::string property;                                        // SameAs: residue, name, type, resname, resid, resnum, segid
  std::vector<std::unique_ptr<SelectionNode>> children;       // Not: 1; And, Or: 2; Around, Sphzone, Within, SameAs: 1
};

class AtomSelection {
public:
  const std::string& text() const { return text_; }
  // True when the result depends on positions (around, sphzone, within): a trajectory evaluates it
  // at every frame; other selections once.
  bool depends_on_positions() const { return geometric_; }
  // Indices of the selected atoms, ascending. `positions` has one entry per atom of `topology`;
  // distances use the minimum image of `cell` when there is one (MDAnalysis's periodic=True).
  std::vector<std::uint32_t> evaluate(const AtomTopology& topology, const std::vector<Vec3>& positions,
                                      const std::optional<CellDimensions>& cell) const;

private:
  friend std::shared_ptr<const AtomSelection> parse_selection(const std::string& text);
  std::string text_;
  std::unique_ptr<SelectionNode> root_;
  bool geometric_ = false;
};

// Throws Error "at character N: expected …, found …" (N 1-based) on a malformed selection.
std::shared_ptr<const AtomSelection> parse_selection(const std::string& text);

}  // namespace penumbra
