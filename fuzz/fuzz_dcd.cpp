// CHARMM/NAMD .dcd trajectories through open_trajectory (fuzz_trajectory.h).
#include "fuzz_trajectory.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  return penumbra::fuzz::fuzz_trajectory("in.dcd", data, size);
}
