// Raw volumes: the first bytes choose the options (dimensions, type, byte order, header bytes), the rest
// is the file.
#include <fuzzer/FuzzedDataProvider.h>

#include <vector>

#include "fuzz_common.h"
#include "penumbra/data/io/volume_io.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  FuzzedDataProvider fdp(data, size);
  penumbra::RawVolumeOptions o;
  for (auto& d : o.dims) d = fdp.ConsumeBool() ? fdp.ConsumeIntegralInRange<std::int64_t>(-2, 40) : fdp.ConsumeIntegral<std::int64_t>();
  o.type = fdp.PickValueInArray({penumbra::ScalarType::UInt8, penumbra::ScalarType::Int16, penumbra::ScalarType::UInt16,
                                 penumbra::ScalarType::Float32});
  o.big_endian = fdp.ConsumeBool();
  for (int a = 0; a < 3; ++a) o.spacing[a] = fdp.ConsumeFloatingPoint<float>();
  o.header_bytes = fdp.ConsumeBool() ? fdp.ConsumeIntegralInRange<std::uint64_t>(0, 64) : fdp.ConsumeIntegral<std::uint64_t>();
  const std::vector<std::uint8_t> file = fdp.ConsumeRemainingBytes<std::uint8_t>();
  const std::string path = penumbra::fuzz::write_input("in.raw", file.data(), file.size());
  penumbra::fuzz::expect_error_or_result([&] { (void)penumbra::load_volume(path, o); });
  return 0;
}
