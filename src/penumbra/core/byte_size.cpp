#include "penumbra/core/byte_size.h"

#include <cctype>
#include <cmath>
#include <cstdio>

#include "penumbra/core/error.h"

namespace penumbra {

std::uint64_t parse_byte_size(const std::string& text) {
  const auto fail = [&] {
    return Error("memory size '" + text + "' (expected a number of bytes, or one with a unit: 512M, 4G, 1.5GiB, 2T)");
  };
  std::size_t i = 0;
  while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
  const std::size_t start = i;
  while (i < text.size() && (std::isdigit(static_cast<unsigned char>(text[i])) || text[i] == '.')) ++i;
  if (i == start) throw fail();
  double value = 0;
  try {
    std::size_t used = 0;
    value = std::stod(text.substr(start, i - start), &used);
    if (used != i - start) throw fail();
  } catch (const std::logic_error&) {
    throw fail();
  }
  while (i < text.size() && std::isspace(static_cast<unsigned char>(text[i]))) ++i;
  std::string unit;
  for (; i < text.size(); ++i) unit += static_cast<char>(std::toupper(static_cast<unsigned char>(text[i])));
  while (!unit.empty() && std::isspace(static_cast<unsigned char>(unit.back()))) unit.pop_back();
  double scale = 1;
  if (!unit.empty() && unit != "B") {
    const char prefix = unit[0];
    const std::string rest = unit.substr(1);
    if (rest != "" && rest != "B" && rest != "IB") throw fail();
    switch (prefix) {
      case 'K': scale = 1024.0; break;
      case 'M': scale = 1024.0 * 1024; break;
      case 'G': scale = 1024.0 * 1024 * 1024; break;
      case 'T': scale = 1024.0 * 1024 * 1024 * 1024; break;
      default: throw fail();
    }
  }
  const double bytes = std::floor(value * scale);
  if (!(bytes >= 1) || bytes > 1e18) throw fail();
  return static_cast<std::uint64_t>(bytes);
}

std::string byte_size_string(std::uint64_t bytes) {
  const char* units[] = {"B", "KiB", "MiB", "GiB", "TiB"};
  double v = static_cast<double>(bytes);
  int u = 0;
  while (v >= 1024 && u < 4) {
    v /= 1024;
    ++u;
  }
  char text[32];
  if (u == 0) std::snprintf(text, sizeof text, "%llu B", static_cast<unsigned long long>(bytes));
  else std::snprintf(text, sizeof text, v < 10 ? "%.2g %s" : "%.0f %s", v, units[u]);
  return text;
}

}  // namespace penumbra
