// gemmi's own writers for the tests (gemmi_writer.cpp, the one test unit that includes gemmi): an
// independent way to turn a PDB text into mmCIF, to check penumbra's mmCIF readers against.
#pragma once

#include <string>

namespace penumbra::test {

// The PDB text (every model) as an mmCIF document written by gemmi (make_mmcif_document +
// write_cif_to_stream). Throws what gemmi throws.
std::string pdb_to_mmcif_with_gemmi(const std::string& pdb_text);

}  // namespace penumbra::test
