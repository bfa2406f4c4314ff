// TIFF stacks through load_volume: the input as a .tif, read with channel 0 and, when the input's last
// byte is odd, with channel 1 too (the hyperstack and multi-sample paths); windows of its pages against
// the whole read (fuzz_common.h expect_windows_match).
#include "fuzz_common.h"
#include "penumbra/data/io/volume_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string path = penumbra::fuzz::write_input("in.tif", data, size);
  penumbra::fuzz::expect_error_or_result([&] { (void)penumbra::load_volume(path); });
  if (size > 0 && (data[size - 1] & 1)) {
    penumbra::VolumeLoadOptions options;
    options.channel = 1;
    penumbra::fuzz::expect_error_or_result([&] { (void)penumbra::load_volume(path, options); });
    penumbra::fuzz::expect_windows_match({path}, options);
  } else {
    penumbra::fuzz::expect_windows_match({path}, {});
  }
  return 0;
}
