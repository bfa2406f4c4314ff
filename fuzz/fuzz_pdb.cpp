// PDB files through load_particles (fuzz_particles.h).
#include "fuzz_particles.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return penumbra::fuzz::fuzz_particles("in.pdb", data, size);
}
