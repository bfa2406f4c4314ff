// gemmi's mmCIF writer for the tests (gemmi_writer.h). Debian's gemmi-dev leaves out the bundled
// stb_sprintf that the writers format numbers with, so std::snprintf stands in (USE_STD_SNPRINTF).
#include "gemmi_writer.h"

#include <sstream>

#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wconversion"
#pragma GCC diagnostic ignored "-Wshadow"
#pragma GCC diagnostic ignored "-Wpedantic"
#pragma GCC diagnostic ignored "-Wsign-conversion"
#pragma GCC diagnostic ignored "-Wunused-parameter"
#define USE_STD_SNPRINTF
#define GEMMI_WRITE_IMPLEMENTATION
#include <gemmi/pdb.hpp>
#include <gemmi/to_cif.hpp>
#include <gemmi/to_mmcif.hpp>
#pragma GCC diagnostic pop

namespace penumbra::test {

std::string pdb_to_mmcif_with_gemmi(const std::string& pdb_text) {
  const gemmi::Structure st = gemmi::read_pdb_string(pdb_text, "converted");
  std::ostringstream out;
  gemmi::cif::write_cif_to_stream(out, gemmi::make_mmcif_document(st));
  return out.str();
}

}  // namespace penumbra::test
