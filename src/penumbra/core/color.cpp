#include "penumbra/core/color.h"

#include <bit>
#include <limits>

namespace penumbra::detail {
namespace {

long srgb_byte_of(float v) { return std::lround(linear_to_srgb(v) * 255.0f); }

SrgbByteTable make_srgb_byte_table() {
  SrgbByteTable t{};
  for (int k = 0; k < 255; ++k) {  // bisection over the bit patterns of non-negative floats (ordered like their values)
    std::uint32_t lo = 0, hi = std::bit_cast<std::uint32_t>(1.0f);  // byte(lo) <= k < byte(hi)
    while (hi - lo > 1) {
      const std::uint32_t mid = lo + (hi - lo) / 2;
      (srgb_byte_of(std::bit_cast<float>(mid)) > k ? hi : lo) = mid;
    }
    t.steps[static_cast<std::size_t>(k)] = std::bit_cast<float>(hi);
  }
  t.steps[255] = std::numeric_limits<float>::infinity();  // no byte above 255
  // one bucket back: v * 4096 may round up into the next bucket
  for (std::size_t i = 0; i < t.below.size(); ++i)
    t.below[i] = static_cast<std::uint8_t>(srgb_byte_of(static_cast<float>(i == 0 ? 0 : i - 1) / 4096.0f));
  return t;
}

}  // namespace

const SrgbByteTable srgb_byte_table = make_srgb_byte_table();

}  // namespace penumbra::detail
