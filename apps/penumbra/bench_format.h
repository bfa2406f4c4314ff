// Numbers in the bench tables: one printf-formatted value; NaN (a figure not measured) prints "—".
#pragma once

#include <cmath>
#include <cstdio>
#include <string>

namespace penumbra::cli {

inline std::string fmt(const char* format, double value) {
  if (std::isnan(value)) return "—";
  char b[64];
  std::snprintf(b, sizeof b, format, value);
  return b;
}

}  // namespace penumbra::cli
