// NIfTI-1 through load_volume: .nii, or .nii.gz when the input starts with the gzip magic; windows of its
// slices against the whole read (fuzz_common.h expect_windows_match).
#include "fuzz_common.h"
#include "penumbra/data/io/volume_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const bool gz = size >= 2 && data[0] == 0x1f && data[1] == 0x8b;
  const std::string path = penumbra::fuzz::write_input(gz ? "in.nii.gz" : "in.nii", data, size);
  penumbra::fuzz::expect_error_or_result([&] { (void)penumbra::load_volume(path); });
  penumbra::fuzz::expect_windows_match({path}, {});
  return 0;
}
