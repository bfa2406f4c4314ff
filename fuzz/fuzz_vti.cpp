// VTK XML ImageData through load_volume: the input as a .vti; windows of its slices against the whole
// read (fuzz_common.h expect_windows_match).
#include "fuzz_common.h"
#include "penumbra/data/io/volume_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = penumbra::fuzz::write_input("in.vti", data, size);
  penumbra::fuzz::expect_error_or_result([&] { (void)penumbra::load_volume(path); });
  penumbra::fuzz::expect_windows_match({path}, {});
  return 0;
}
