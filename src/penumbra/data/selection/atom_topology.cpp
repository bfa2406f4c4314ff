// AtomTopology and MDAnalysis's atom type guesser (MDAnalysis.topology.guessers.guess_atom_element
// with the tables of MDAnalysis.topology.tables).
#include "penumbra/data/selection/atom_topology.h"

#include <algorithm>
#include <cctype>
#include <unordered_map>

namespace penumbra {

std::uint32_t StringTable::intern(std::string_view s) {
  const auto [it, inserted] = index_.emplace(std::string(s), static_cast<std::uint32_t>(strings_.size()));
  if (inserted) strings_.push_back(it->first);
  return it->second;
}

std::size_t StringTable::memory_bytes() const {
  std::size_t bytes = strings_.capacity() * sizeof(std::string) * 2;
  for (const std::string& s : strings_) bytes += 2 * s.capacity();
  return bytes;
}

std::size_t AtomTopology::memory_bytes() const {
  return strings.memory_bytes() +
         (names.capacity() + resnames.capacity() + types.capacity() + segids.capacity() + chain_ids.capacity() +
          resids.capacity() + resnums.capacity() + residues.capacity()) * 4;
}

void AtomTopology::reserve(std::size_t n) {
  for (auto* v : {&names, &resnames, &types, &segids, &chain_ids, &residues}) v->reserve(n);
  resids.reserve(n);
  resnums.reserve(n);
}

void AtomTopology::add(std::string_view name, std::string_view resname, std::string_view type, std::string_view segid,
                       std::string_view chain_id, std::int32_t resid, std::int32_t resnum) {
  const std::uint32_t rn = strings.intern(resname), sg = strings.intern(segid), ch = strings.intern(chain_id);
  std::uint32_t residue = 0;
  if (!residues.empty()) {
    const std::size_t last = residues.size() - 1;
    const bool same = resids[last] == resid && resnames[last] == rn && segids[last] == sg && chain_ids[last] == ch;
    residue = residues[last] + (same ? 0 : 1);
  }
  names.push_back(strings.intern(name));
  resnames.push_back(rn);
  types.push_back(strings.intern(type));
  segids.push_back(sg);
  chain_ids.push_back(ch);
  resids.push_back(resid);
  resnums.push_back(resnum);
  residues.push_back(residue);
}

namespace {

std::string upper_case(std::string_view s) {
  std::string u(s);
  for (char& c : u) c = static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  return u;
}

// MDAnalysis.topology.tables.atomelements: names whose first letter is not their element.
const std::unordered_map<std::string, std::string>& named_elements() {
  static const std::unordered_map<std::string, std::string> table{
      {"AC", "C"},   {"BC", "C"},   {"BR", "BR"},  {"C0", "CA"},  {"CA2+", "CA"}, {"CAL", "CA"}, {"CES", "CS"},
      {"CL", "CL"},  {"CL-", "CL"}, {"CLA", "CL"}, {"CLAL", "CL"}, {"CS", "CS"},  {"CS+", "CS"},  {"CU", "CU"},
      {"FE", "FE"},  {"FE2", "FE"}, {"IOD", "I"},  {"K", "K"},    {"K+", "K"},    {"LI", "LI"},   {"LI+", "LI"},
      {"LIT", "LI"}, {"MG", "MG"},  {"MG2+", "MG"}, {"MW", "DUMMY"}, {"NA", "NA"}, {"NA+", "NA"}, {"POT", "K"},
      {"QC", "CE"},  {"QK", "K"},   {"QL", "LI"},  {"QN", "NA"},  {"QR", "RB"},   {"RB", "RB"},   {"SOD", "NA"},
      {"ZN", "ZN"}};
  return table;
}

// MDAnalysis.topology.tables.elements.
bool known_element(std::string_view s) {
  static const char* const kElements[] = {"AL", "B", "BE", "C", "CL", "F", "H", "K", "LI", "MG", "N", "NA", "O", "P", "S", "SI"};
  return std::any_of(std::begin(kElements), std::end(kElements), [&](const char* e) { return s == e; });
}

}  // namespace

std::string guess_atom_type(std::string_view atom_name) {
  if (atom_name.empty()) return "";
  const auto& table = named_elements();
  if (const auto it = table.find(upper_case(atom_name)); it != table.end()) return it->second;
  std::string no_symbols, name;
  for (const char c : atom_name)
    if (c != '*' && c != '+' && c != '-') no_symbols += c;
  for (const char c : no_symbols)
    if (!std::isdigit(static_cast<unsigned char>(c))) name += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (const auto it = table.find(name); it != table.end()) return it->second;
  while (!name.empty()) {
    if (known_element(name)) return name;
    if (known_element(std::string_view(name).substr(0, name.size() - 1))) return name.substr(0, name.size() - 1);
    if (known_element(std::string_view(name).substr(1))) return name.substr(1);
    if (name.size() <= 2) return name.substr(0, 1);
    name.pop_back();
  }
  return no_symbols;
}

}  // namespace penumbra
