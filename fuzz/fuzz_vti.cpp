// VTK XML ImageData through load_volume: the input as a .vti.
#include "fuzz_common.h"
#include "penumbra/data/io/volume_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = penumbra::fuzz::write_input("in.vti", data, size);
  penumbra::fuzz::expect_error_or_result([&] { (void)penumbra::load_volume(path); });
  return 0;
}
