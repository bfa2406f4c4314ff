// The element table (symbol, van der Waals radius, Jmol CPK colour) and the chain and residue palettes;
// sources in elements.h. Colours are written as the sRGB hex codes of their tables and converted to
// linear RGB once, on first use.
#include "penumbra/data/elements.h"

#include <array>
#include <cctype>
#include <string>

#include "penumbra/data/io/text_fields.h"

namespace penumbra {

namespace {

struct ElementRow {
  const char* symbol;
  float radius;        // Å
  std::uint32_t srgb;  // 0xRRGGBB, Jmol
};

// Index = atomic number. Radius sources: B = Bondi 1964, A = Alvarez 2013, M = Mantina 2009.
constexpr std::array<ElementRow, kMaxElement + 1> kElements{{
    {"X", 1.70f, 0x808080},   // unknown: carbon-sized, mid grey
    {"H", 1.20f, 0xFFFFFF},   // B
    {"He", 1.40f, 0xD9FFFF},  // B
    {"Li", 1.82f, 0xCC80FF},  // B
    {"Be", 1.98f, 0xC2FF00},  // A
    {"B", 1.91f, 0xFFB5B5},   // A
    {"C", 1.70f, 0x909090},   // B
    {"N", 1.55f, 0x3050F8},   // B
    {"O", 1.52f, 0xFF0D0D},   // B
    {"F", 1.47f, 0x90E050},   // B
    {"Ne", 1.54f, 0xB3E3F5},  // B
    {"Na", 2.27f, 0xAB5CF2},  // B
    {"Mg", 1.73f, 0x8AFF00},  // B
    {"Al", 2.25f, 0xBFA6A6},  // A
    {"Si", 2.10f, 0xF0C8A0},  // B
    {"P", 1.80f, 0xFF8000},   // B
    {"S", 1.80f, 0xFFFF30},   // B
    {"Cl", 1.75f, 0x1FF01F},  // B
    {"Ar", 1.88f, 0x80D1E3},  // B
    {"K", 2.75f, 0x8F40D4},   // B
    {"Ca", 2.62f, 0x3DFF00},  // A
    {"Sc", 2.58f, 0xE6E6E6},  // A
    {"Ti", 2.46f, 0xBFC2C7},  // A
    {"V", 2.42f, 0xA6A6AB},   // A
    {"Cr", 2.45f, 0x8A99C7},  // A
    {"Mn", 2.45f, 0x9C7AC7},  // A
    {"Fe", 2.44f, 0xE06633},  // A
    {"Co", 2.40f, 0xF090A0},  // A
    {"Ni", 1.63f, 0x50D050},  // B
    {"Cu", 1.40f, 0xC88033},  // B
    {"Zn", 1.39f, 0x7D80B0},  // B
    {"Ga", 1.87f, 0xC28F8F},  // B
    {"Ge", 2.29f, 0x668F8F},  // A
    {"As", 1.85f, 0xBD80E3},  // B
    {"Se", 1.90f, 0xFFA100},  // B
    {"Br", 1.85f, 0xA62929},  // B
    {"Kr", 2.02f, 0x5CB8D1},  // B
    {"Rb", 3.21f, 0x702EB0},  // A
    {"Sr", 2.84f, 0x00FF00},  // A
    {"Y", 2.75f, 0x94FFFF},   // A
    {"Zr", 2.52f, 0x94E0E0},  // A
    {"Nb", 2.56f, 0x73C2C9},  // A
    {"Mo", 2.45f, 0x54B5B5},  // A
    {"Tc", 2.44f, 0x3B9E9E},  // A
    {"Ru", 2.46f, 0x248F8F},  // A
    {"Rh", 2.44f, 0x0A7D8C},  // A
    {"Pd", 1.63f, 0x006985},  // B
    {"Ag", 1.72f, 0xC0C0C0},  // B
    {"Cd", 1.58f, 0xFFD98F},  // B
    {"In", 1.93f, 0xA67573},  // B
    {"Sn", 2.17f, 0x668080},  // B
    {"Sb", 2.47f, 0x9E63B5},  // A
    {"Te", 2.06f, 0xD47A00},  // B
    {"I", 1.98f, 0x940094},   // B
    {"Xe", 2.16f, 0x429EB0},  // B
    {"Cs", 3.48f, 0x57178F},  // A
    {"Ba", 3.03f, 0x00C900},  // A
    {"La", 2.98f, 0x70D4FF},  // A
    {"Ce", 2.88f, 0xFFFFC7},  // A
    {"Pr", 2.92f, 0xD9FFC7},  // A
    {"Nd", 2.95f, 0xC7FFC7},  // A
    {"Pm", 2.92f, 0xA3FFC7},  // interpolated between Nd and Sm
    {"Sm", 2.90f, 0x8FFFC7},  // A
    {"Eu", 2.87f, 0x61FFC7},  // A
    {"Gd", 2.83f, 0x45FFC7},  // A
    {"Tb", 2.79f, 0x30FFC7},  // A
    {"Dy", 2.87f, 0x1FFFC7},  // A
    {"Ho", 2.81f, 0x00FF9C},  // A
    {"Er", 2.83f, 0x00E675},  // A
    {"Tm", 2.79f, 0x00D452},  // A
    {"Yb", 2.80f, 0x00BF38},  // A
    {"Lu", 2.74f, 0x00AB24},  // A
    {"Hf", 2.63f, 0x4DC2FF},  // A
    {"Ta", 2.53f, 0x4DA6FF},  // A
    {"W", 2.57f, 0x2194D6},   // A
    {"Re", 2.49f, 0x267DAB},  // A
    {"Os", 2.48f, 0x266696},  // A
    {"Ir", 2.41f, 0x175487},  // A
    {"Pt", 1.72f, 0xD0D0E0},  // B
    {"Au", 1.66f, 0xFFD123},  // B
    {"Hg", 1.55f, 0xB8B8D0},  // B
    {"Tl", 1.96f, 0xA6544D},  // B
    {"Pb", 2.02f, 0x575961},  // B
    {"Bi", 2.54f, 0x9E4FB5},  // A
    {"Po", 1.97f, 0xAB5C00},  // M
    {"At", 2.02f, 0x754F45},  // M
    {"Rn", 2.20f, 0x428296},  // M
    {"Fr", 3.48f, 0x420066},  // M
    {"Ra", 2.83f, 0x007D00},  // M
    {"Ac", 2.80f, 0x70ABFA},  // A
    {"Th", 2.93f, 0x00BAFF},  // A
    {"Pa", 2.88f, 0x00A1FF},  // A
    {"U", 1.86f, 0x008FFF},   // B
}};

// ColorBrewer "Paired": the six dark colours, then the six light ones.
constexpr std::array<std::uint32_t, kChainPaletteSize> kChainPalette{
    0x1F78B4, 0x33A02C, 0xE31A1C, 0xFF7F00, 0x6A3D9A, 0xB15928,
    0xA6CEE3, 0xB2DF8A, 0xFB9A99, 0xFDBF6F, 0xCAB2D6, 0xFFFF99};

// Residue keys: 0 other; 1-20 the amino acids in this order; 21-25 the nucleotides A, C, G, T, U.
constexpr std::array<const char*, 20> kAminoAcids{"ALA", "ARG", "ASN", "ASP", "CYS", "GLN", "GLU",
                                                  "GLY", "HIS", "ILE", "LEU", "LYS", "MET", "PHE",
                                                  "PRO", "SER", "THR", "TRP", "TYR", "VAL"};
constexpr std::array<std::uint32_t, 26> kResiduePalette{
    0x808080,  // other
    // RasMol "amino": ALA ARG ASN ASP CYS GLN GLU GLY HIS ILE LEU LYS MET PHE PRO SER THR TRP TYR VAL
    0xC8C8C8, 0x145AFF, 0x00DCDC, 0xE60A0A, 0xE6E600, 0x00DCDC, 0xE60A0A, 0xEBEBEB, 0x8282D2, 0x0F820F,
    0x0F820F, 0x145AFF, 0xE6E600, 0x3232AA, 0xDC9682, 0xFA9600, 0xFA9600, 0xB45AB4, 0x3232AA, 0x0F820F,
    // Jmol "shapely" nucleotides: A C G T U
    0xA0A0FF, 0xFF8C4B, 0xFF7070, 0xA0FFA0, 0xFF8080};

Rgb linear_from_hex(std::uint32_t srgb) {
  auto channel = [&](int shift) {
    return srgb_to_linear(static_cast<float>((srgb >> shift) & 0xFFu) / 255.0f);
  };
  return {channel(16), channel(8), channel(0)};
}

template <std::size_t N>
std::array<Rgb, N> linear_table(const std::array<std::uint32_t, N>& hex) {
  std::array<Rgb, N> out;
  for (std::size_t i = 0; i < N; ++i) out[i] = linear_from_hex(hex[i]);
  return out;
}

const std::array<Rgb, kMaxElement + 1>& element_colors() {
  static const std::array<Rgb, kMaxElement + 1> colors = [] {
    std::array<std::uint32_t, kMaxElement + 1> hex{};
    for (std::size_t i = 0; i < kElements.size(); ++i) hex[i] = kElements[i].srgb;
    return linear_table(hex);
  }();
  return colors;
}

std::string upper_trimmed(std::string_view s) { return io_detail::upper(io_detail::trim(s)); }

}  // namespace

int element_from_symbol(std::string_view symbol) {
  const std::string s = upper_trimmed(symbol);
  if (s.empty() || s.size() > 2) return kUnknownElement;
  if (s == "D" || s == "T") return kHydrogen;
  for (int z = 1; z <= kMaxElement; ++z) {
    const char* e = kElements[static_cast<std::size_t>(z)].symbol;
    const char e1 = e[1] ? static_cast<char>(std::toupper(static_cast<unsigned char>(e[1]))) : '\0';
    if (s[0] == e[0] && (s.size() == 1 ? e1 == '\0' : s[1] == e1)) return z;
  }
  return kUnknownElement;
}

const char* element_symbol(int element) {
  return element > 0 && element <= kMaxElement ? kElements[static_cast<std::size_t>(element)].symbol : "X";
}

float element_vdw_radius(int element) {
  return kElements[element > 0 && element <= kMaxElement ? static_cast<std::size_t>(element) : 0].radius;
}

Rgb element_color(int element) {
  return element_colors()[element > 0 && element <= kMaxElement ? static_cast<std::size_t>(element) : 0];
}

Rgb chain_color(std::size_t chain_index) {
  static const std::array<Rgb, kChainPaletteSize> colors = linear_table(kChainPalette);
  return colors[chain_index % kChainPaletteSize];
}

ResidueColorKey residue_color_key(std::string_view residue_name) {
  std::string s = upper_trimmed(residue_name);
  if (s == "HID" || s == "HIE" || s == "HIP" || s == "HSD" || s == "HSE" || s == "HSP") s = "HIS";
  if (s == "CYX") s = "CYS";
  if (s == "MSE") s = "MET";
  for (std::size_t i = 0; i < kAminoAcids.size(); ++i)
    if (s == kAminoAcids[i]) return static_cast<ResidueColorKey>(1 + i);
  if (s == "ADE") s = "A";
  if (s == "CYT") s = "C";
  if (s == "GUA") s = "G";
  if (s == "THY") s = "T";
  if (s == "URA") s = "U";
  // AMBER terminal variants (DA5, RU3, A5) and DNA / RNA prefixes (DA, RA).
  if (s.size() >= 2 && (s.back() == '5' || s.back() == '3')) s.pop_back();
  if (s.size() == 2 && (s[0] == 'D' || s[0] == 'R')) s.erase(0, 1);
  static constexpr std::string_view kBases = "ACGTU";
  if (s.size() == 1) {
    const std::size_t pos = kBases.find(s[0]);
    if (pos != std::string_view::npos) return static_cast<ResidueColorKey>(21 + pos);
  }
  return kOtherResidue;
}

Rgb residue_color(ResidueColorKey key) {
  static const std::array<Rgb, kResiduePalette.size()> colors = linear_table(kResiduePalette);
  return colors[key < colors.size() ? key : 0];
}

}  // namespace penumbra
