// OpenVDB grids through load_volume: the input as a .vdb. OpenVDB itself parses in a child process
// (vdb_loader.cpp); what is fuzzed here is penumbra's side: the layout check before OpenVDB sees the
// file, the pipe protocol and the bricked volume built from the child's answer.
#include "fuzz_common.h"
#include "penumbra/data/io/volume_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = penumbra::fuzz::write_input("in.vdb", data, size);
  penumbra::fuzz::expect_error_or_result([&] { (void)penumbra::load_volume(path); });
  return 0;
}
