// Sizes of memory as users write them: "4G", "512 MiB", "1.5GB", "3000000" (bytes). K, M, G and T
// (with or without B, iB) are powers of 1024, as `free -h` and ParaView's memory inspector count.
#pragma once

#include <cstdint>
#include <string>

namespace penumbra {

// Error naming `text` and the forms expected for anything else (a negative, zero or absurd size, an
// unknown unit).
std::uint64_t parse_byte_size(const std::string& text);
// "1.5 GiB", "512 MiB", "12 KiB", "100 B": for messages.
std::string byte_size_string(std::uint64_t bytes);

}  // namespace penumbra
