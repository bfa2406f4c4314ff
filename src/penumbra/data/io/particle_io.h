// Particle files: PDB (.pdb, .ent) and mmCIF (.cif, .mmcif) through gemmi, GROMACS .gro (nm, converted
// to Å) and XYZ; each optionally gzip-compressed (.gz). Radii are van der Waals radii per element,
// colours CPK per element, or per chain / residue, or one colour. Biological assemblies (PDB REMARK 350
// BIOMT, mmCIF pdbx_struct_assembly_gen + pdbx_struct_oper_list) are built by applying the operators
// to the packed coordinates of the chains they name. World units are ångström.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "penumbra/data/particles.h"
#include "penumbra/data/selection/atom_topology.h"
#include "penumbra/data/selection/selection.h"
#include "penumbra/data/transfer_function.h"

namespace penumbra {

enum class ParticleColoring { Element, Chain, Residue, Uniform, Scalar };

// The per-atom value `ParticleColoring::Scalar` maps through a colour map: the B-factor or occupancy
// of PDB/mmCIF atoms, or the atom's index in the file (any format; a rainbow along the chain).
enum class ParticleScalar { BFactor, Occupancy, Index };

struct ParticleLoadOptions {
  int assembly = 0;                   // 0: the deposited coordinates; n ≥ 1: biological assembly n
  ParticleColoring coloring = ParticleColoring::Element;
  Rgb uniform_color{0.8f, 0.8f, 0.8f};  // for ParticleColoring::Uniform
  float radius_scale = 1;             // multiplies the van der Waals radius
  bool hydrogens = true;              // false drops H and D atoms
  ParticleScalar scalar = ParticleScalar::BFactor;  // for ParticleColoring::Scalar
  // The colour map of ParticleColoring::Scalar, made for the value range [lo, hi] of the atoms kept
  // (a transfer function's colour is used, its opacity ignored); null: ParaView's "Cool to Warm".
  std::function<TransferFunction(float lo, float hi)> color_map;
  // An assembly with more spheres than this is refused (with a message) before anything is allocated.
  std::uint64_t max_spheres = std::uint64_t{1} << 30;
  // The atoms to keep (null: all), evaluated on the file's atoms and coordinates — `index` is an
  // atom's 0-based position in the file — before hydrogens are dropped and the assembly is built.
  std::shared_ptr<const AtomSelection> selection;
};

// What a load produced besides the spheres, for `penumbra info` and --stats.
struct ParticleFileInfo {
  std::string format;           // "pdb", "mmcif", "gro", "xyz"
  std::size_t atoms_in_file = 0;  // atoms of the model read (before the assembly)
  int operators = 0;            // assembly operators applied (0: none)
  std::size_t unknown_elements = 0;  // atoms whose element was not recognised (drawn as carbon-sized grey)
  float scalar_min = 0, scalar_max = 0;  // the range ParticleColoring::Scalar mapped
  std::size_t selected_atoms = 0;  // atoms of the file the selection kept (all atoms without one)
};

// A particle file as read: its atoms, their topology and the assemblies, before radii, colours and
// selections are applied; one reading serves every particle set built from the file.
struct ParticleFile;

// Throws Error naming the file (and line where there is one) on unreadable or malformed input.
std::shared_ptr<const ParticleFile> read_particle_file(const std::string& path);
const AtomTopology& topology_of(const ParticleFile& file);
const std::vector<Vec3>& positions_of(const ParticleFile& file);  // Å, in file order
// The spheres of `file` under `options`; Error naming the file when the options do not fit it.
ParticleSet build_particles(const ParticleFile& file, const ParticleLoadOptions& options, ParticleFileInfo* info = nullptr);

// read_particle_file then build_particles.
ParticleSet load_particles(const std::string& path, const ParticleLoadOptions& options,
                           ParticleFileInfo* info = nullptr);

// "pdb", "mmcif", "gro", "xyz" by the file name's extension (a .gz suffix ignored); "" for others.
std::string particle_file_format(const std::string& path);

std::string to_string(ParticleColoring c);
std::string to_string(ParticleScalar s);  // "b_factor", "occupancy", "index"
ParticleScalar particle_scalar_from_string(const std::string& s);  // Error listing the names
ParticleColoring particle_coloring_from_string(const std::string& s);  // Error listing the names

}  // namespace penumbra
