// Chemical elements for drawing atoms: symbol, van der Waals radius and CPK colour per element, plus the
// chain and residue palettes of the other colourings. Elements are indexed by atomic number (H = 1 …
// U = 92); index 0 (kUnknownElement) stands for anything not recognised.
//
// Radii (Å): Bondi 1964 (J. Phys. Chem. 68, 441) for the elements it lists; Alvarez 2013 ("A cartography
// of the van der Waals territories", Dalton Trans. 42, 8617) for the others; Mantina et al. 2009 (J. Phys.
// Chem. A 113, 5806) for Po, At, Rn, Fr and Ra, which Alvarez leaves out; Pm, missing from all three, is
// interpolated between Nd and Sm. Colours: the Jmol CPK table (sRGB), stored converted to linear RGB.
// Unknown elements: radius 1.7 Å (carbon's) and mid grey; loaders count them (ParticleFileInfo).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string_view>

#include "penumbra/core/color.h"

namespace penumbra {

constexpr int kUnknownElement = 0;
constexpr int kHydrogen = 1;
constexpr int kMaxElement = 92;  // the table covers H … U

// Atomic number for an element symbol, any case ("C", "CL", "cl", "Fe"); D and T (deuterium, tritium)
// give hydrogen. kUnknownElement when the symbol is not an element of the table.
int element_from_symbol(std::string_view symbol);

const char* element_symbol(int element);  // "X" for kUnknownElement or out of range
float element_vdw_radius(int element);     // Å; 1.7 for kUnknownElement or out of range
Rgb element_color(int element);            // linear RGB; grey for kUnknownElement or out of range

// Chain colouring: a fixed palette of 12 colours (ColorBrewer "Paired", its six dark colours first, then
// the six light ones, so neighbouring chains differ in hue), indexed by the chain's order of first
// appearance in the file, modulo 12. Linear RGB.
constexpr std::size_t kChainPaletteSize = 12;
Rgb chain_color(std::size_t chain_index);

// Residue colouring: the RasMol/Jmol "amino" colours for the 20 amino acids (with common variant names:
// HID/HIE/HIP/HSD/HSE/HSP → HIS, CYX → CYS, MSE → MET) and the Jmol "shapely" nucleotide colours for A,
// C, G, T, U (RNA names, DNA names DA…DT, and AMBER's 5'/3' variants such as DA5, RU3); any other residue
// (water, ions, ligands, lipids) is key 0, mid grey. The key is what loaders store per atom.
using ResidueColorKey = std::uint8_t;
constexpr ResidueColorKey kOtherResidue = 0;
ResidueColorKey residue_color_key(std::string_view residue_name);  // name trimmed of blanks, any case
Rgb residue_color(ResidueColorKey key);                             // linear RGB

}  // namespace penumbra
