// Internal to the particle loaders: the packed form every particle file is read into (one entry per
// atom in flat arrays, no per-atom objects), and the PDB / mmCIF reader that fills it through gemmi.
// molecule_gemmi.cpp is the only translation unit that includes gemmi (its headers compile slowly).
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "penumbra/core/math.h"
#include "penumbra/data/elements.h"
#include "penumbra/data/selection/atom_topology.h"

namespace penumbra::io_detail {

// An assembly operator: x' = R x + t, row-major as [R | t] (PDB REMARK 350 BIOMT rows; mmCIF
// pdbx_struct_oper_list matrix[i][j] and vector[i]).
using AssemblyOperator = std::array<double, 12>;

// One generator of an assembly: every operator applied to every atom of the named units. The units
// are PDB chain identifiers ("APPLY THE FOLLOWING TO CHAINS:") or mmCIF label_asym_ids
// (pdbx_struct_assembly_gen.asym_id_list), matching PackedMolecule::unit_names.
struct AssemblyGenerator {
  std::vector<std::string> units;
  std::vector<AssemblyOperator> operators;
};

struct MoleculeAssembly {
  std::string name;  // the file's id for it ("1", "2", …)
  std::vector<AssemblyGenerator> generators;
};

// The atoms of one model, as structure-of-arrays (all of the same length).
struct PackedMolecule {
  std::vector<Vec3> positions;                // Å, finite
  std::vector<std::uint8_t> elements;         // atomic number (elements.h); kUnknownElement if unrecognised
  std::vector<std::uint32_t> chains;          // index into chain_names
  std::vector<std::uint32_t> units;           // index into unit_names (what assembly generators select)
  std::vector<ResidueColorKey> residue_keys;  // residue_color_key of the residue name
  std::vector<float> b_factors;               // PDB/mmCIF B-factor (Å²); empty for formats without one
  std::vector<float> occupancies;             // PDB/mmCIF occupancy; empty for formats without one
  std::vector<std::string> chain_names;       // author chain ids in order of first appearance
  std::vector<std::string> unit_names;        // PDB: = chain_names; mmCIF: label_asym_ids
  std::vector<MoleculeAssembly> assemblies;   // in file order
  AtomTopology topology;                      // names, residues, … and the unit cell, for selections

  std::size_t size() const { return positions.size(); }
  void reserve(std::size_t n) {
    positions.reserve(n);
    elements.reserve(n);
    chains.reserve(n);
    units.reserve(n);
    residue_keys.reserve(n);
    b_factors.reserve(n);
    occupancies.reserve(n);
    topology.reserve(n);
  }
};

enum class MoleculeFormat { Pdb, Mmcif };

// Reads the first model of a PDB or mmCIF text (already decompressed) and its assemblies. Throws Error
// (without the file name; the caller adds it) on malformed input: PDB ATOM/HETATM lines too short or
// with coordinates that are not finite numbers (naming the line), gemmi parse errors, no atoms.
PackedMolecule read_molecule_gemmi(std::string_view text, MoleculeFormat format, const std::string& name);

// What gemmi 0.5.7's PDB parser must not see (molecule_gemmi.cpp): SSBOND/LINK records shorter than 80
// columns (it reads their distance past the end of a 74- to 77-character record: a heap over-read), NUL
// bytes (they shorten its copy of a line) and bytes above 0x7f (shifts of negative chars). When `text`
// has any, `fixed` receives a copy with those records padded with blanks to 80 columns, NULs made
// blanks and high bytes '?', and the result is true; otherwise false. read_molecule_gemmi applies it to
// every PDB text.
bool pdb_text_for_gemmi(std::string_view text, std::string& fixed);

}  // namespace penumbra::io_detail
