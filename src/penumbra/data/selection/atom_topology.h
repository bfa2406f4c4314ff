// What atom selections (selection.h) read besides positions: per atom its name, residue name, type,
// segment id, chain id, residue number (resid, resnum) and residue, kept compactly as indices into one
// table of distinct strings. Atom i is the i-th atom of the file (0-based `index`). The loaders fill it
// as MDAnalysis's topology parsers do (docs/selections.md); `unit_cell` is the file's periodic box.
#pragma once

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <unordered_map>
#include <vector>

namespace penumbra {

// Distinct strings, each stored once and named by its position.
class StringTable {
public:
  std::uint32_t intern(std::string_view s);
  const std::string& operator[](std::uint32_t i) const { return strings_[i]; }
  std::size_t size() const { return strings_.size(); }
  std::size_t memory_bytes() const;

private:
  std::vector<std::string> strings_;
  std::unordered_map<std::string, std::uint32_t> index_;
};

// A periodic box as MDAnalysis's `dimensions`: a, b, c (Å), alpha, beta, gamma (degrees).
using CellDimensions = std::array<float, 6>;

struct AtomTopology {
  StringTable strings;                  // every name below is an index into it
  std::vector<std::uint32_t> names, resnames, types, segids, chain_ids;
  std::vector<std::int32_t> resids, resnums;
  std::vector<std::uint32_t> residues;  // residue of the atom (MDAnalysis's resindex), 0, 1, … in file order
  std::optional<CellDimensions> unit_cell;

  std::size_t size() const { return names.size(); }
  std::size_t memory_bytes() const;
  void reserve(std::size_t n);
  // Appends an atom. A new residue starts where resid, resname, segid or chain id change from the
  // previous atom (MDAnalysis groups consecutive atoms so).
  void add(std::string_view name, std::string_view resname, std::string_view type, std::string_view segid,
           std::string_view chain_id, std::int32_t resid, std::int32_t resnum);
};

// MDAnalysis's guess of an atom's type (its element, upper case) from the atom name, as
// MDAnalysis.topology.guessers.guess_atom_type does for formats without types (GRO, XYZ).
std::string guess_atom_type(std::string_view atom_name);

}  // namespace penumbra
