// VTK scalar types, ASCII values, sample conversion and axis flips shared by the .vti and legacy .vtk
// readers (see vtk_image_data.h).
#include "penumbra/data/io/vtk_image_data.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <type_traits>

#include "penumbra/core/error.h"
#include "penumbra/data/io/text_fields.h"

namespace penumbra::io_detail {

namespace {

struct TypeNames {
  VtkType type;
  const char* xml;
  const char* legacy;
};

constexpr std::array<TypeNames, 10> kTypes{{{VtkType::Int8, "Int8", "char"},
                                            {VtkType::UInt8, "UInt8", "unsigned_char"},
                                            {VtkType::Int16, "Int16", "short"},
                                            {VtkType::UInt16, "UInt16", "unsigned_short"},
                                            {VtkType::Int32, "Int32", "int"},
                                            {VtkType::UInt32, "UInt32", "unsigned_int"},
                                            {VtkType::Int64, "Int64", "vtktypeint64"},
                                            {VtkType::UInt64, "UInt64", "vtktypeuint64"},
                                            {VtkType::Float32, "Float32", "float"},
                                            {VtkType::Float64, "Float64", "double"}}};

template <class T>
T load(const std::byte* p, bool swap) {
  std::array<std::byte, sizeof(T)> b;
  std::memcpy(b.data(), p, sizeof(T));
  if (swap) std::reverse(b.begin(), b.end());
  T v;
  std::memcpy(&v, b.data(), sizeof(T));
  return v;
}

template <class F>
decltype(auto) with_type(VtkType type, F&& f) {
  switch (type) {
    case VtkType::Int8: return f(std::int8_t{});
    case VtkType::UInt8: return f(std::uint8_t{});
    case VtkType::Int16: return f(std::int16_t{});
    case VtkType::UInt16: return f(std::uint16_t{});
    case VtkType::Int32: return f(std::int32_t{});
    case VtkType::UInt32: return f(std::uint32_t{});
    case VtkType::Int64: return f(std::int64_t{});
    case VtkType::UInt64: return f(std::uint64_t{});
    case VtkType::Float32: return f(float{});
    case VtkType::Float64: break;
  }
  return f(double{});
}

// Converts every `step`-th sample; false when a value did not survive the conversion exactly.
template <class Src, class Dst>
bool convert(const std::byte* data, bool swap, std::size_t step, std::size_t n, Dst* out) {
  if constexpr (std::is_same_v<Src, Dst>) {
    if (step == 1 && !swap) {
      std::memcpy(out, data, n * sizeof(Dst));
      return true;
    }
  }
  bool exact = true;
  for (std::size_t i = 0; i < n; ++i) {
    const Src v = load<Src>(data + i * step * sizeof(Src), swap);
    if constexpr (std::is_same_v<Src, double>) {
      if (std::abs(v) > std::numeric_limits<float>::max())
        throw Error("value " + num(v) + " at point " + std::to_string(i) + " is outside the float32 range");
    }
    out[i] = static_cast<Dst>(v);
    if constexpr (std::is_integral_v<Src> && sizeof(Src) >= 4) {
      exact = exact && static_cast<double>(out[i]) == static_cast<double>(v);
    } else if constexpr (std::is_same_v<Src, double>) {
      exact = exact && (static_cast<double>(out[i]) == v || std::isnan(v));
    }
  }
  return exact;
}

}  // namespace

std::optional<VtkType> vtk_type_from_xml(std::string_view name) {
  for (const auto& t : kTypes)
    if (name == t.xml) return t.type;
  return std::nullopt;
}

std::optional<VtkType> vtk_type_from_legacy(std::string_view name) {
  const std::string lower = [&] {
    std::string s(name);
    for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return s;
  }();
  for (const auto& t : kTypes)
    if (lower == t.legacy) return t.type;
  return std::nullopt;
}

std::size_t vtk_type_size(VtkType type) {
  return with_type(type, [](auto v) { return sizeof(v); });
}

const char* vtk_type_name(VtkType type) {
  for (const auto& t : kTypes)
    if (t.type == type) return t.xml;
  return "?";
}

ScalarType vtk_volume_type(VtkType type) {
  switch (type) {
    case VtkType::UInt8: return ScalarType::UInt8;
    case VtkType::Int8: case VtkType::Int16: return ScalarType::Int16;
    case VtkType::UInt16: return ScalarType::UInt16;
    default: return ScalarType::Float32;
  }
}

std::size_t parse_ascii_values(std::string_view text, VtkType type, std::size_t count, std::byte* out) {
  std::size_t pos = 0;
  with_type(type, [&](auto zero) {
    using T = decltype(zero);
    for (std::size_t i = 0; i < count; ++i) {
      pos = text.find_first_not_of(kBlanks, pos);
      if (pos == std::string_view::npos)
        throw Error("ASCII data has " + std::to_string(i) + " values but " + std::to_string(count) + " are needed (truncated data or lying sizes)");
      const std::size_t end = std::min(text.find_first_of(kBlanks, pos), text.size());
      const std::string_view token = text.substr(pos, end - pos);
      double v = 0;
      const bool number = parse_number(token, v);
      T t{};
      if constexpr (std::is_integral_v<T>) {
        const bool fits = number && v == std::floor(v) && v >= static_cast<double>(std::numeric_limits<T>::lowest()) &&
                          v <= static_cast<double>(std::numeric_limits<T>::max());
        if (!fits)
          throw Error("ASCII value " + std::to_string(i) + " '" + printable(token, 40) + "' is not a " + vtk_type_name(type));
        t = static_cast<T>(v);
      } else {
        if (!number) throw Error("ASCII value " + std::to_string(i) + " '" + printable(token, 40) + "' is not a number");
        t = static_cast<T>(v);
      }
      std::memcpy(out + i * sizeof(T), &t, sizeof(T));
      pos = end;
    }
  });
  return pos;
}

bool convert_vtk_samples(const std::byte* data, VtkType type, bool big_endian, std::size_t components, Volume& volume,
                         std::size_t first, std::size_t count) {
  const bool swap = big_endian != (std::endian::native == std::endian::big);
  return with_type(type, [&](auto zero) {
    using Src = decltype(zero);
    switch (volume.type()) {
      case ScalarType::UInt8: return convert<Src>(data, swap, components, count, volume.data_as<std::uint8_t>() + first);
      case ScalarType::Int16: return convert<Src>(data, swap, components, count, volume.data_as<std::int16_t>() + first);
      case ScalarType::UInt16: return convert<Src>(data, swap, components, count, volume.data_as<std::uint16_t>() + first);
      case ScalarType::Float32: break;
    }
    return convert<Src>(data, swap, components, count, volume.data_as<float>() + first);
  });
}

void note_vtk_conversion(VtkType type, std::size_t components, bool exact, std::vector<std::string>& notes) {
  if (components > 1) notes.push_back("component 0 of " + std::to_string(components) + " loaded");
  if (type == VtkType::Int8) notes.push_back("Int8 values stored as int16");
  if (vtk_volume_type(type) == ScalarType::Float32 && type != VtkType::Float32)
    notes.push_back(std::string(vtk_type_name(type)) + " values stored as float32" +
                    (exact ? " (all exact)" : type == VtkType::Float64 ? " (rounded)" : " (values beyond 2^24 rounded)"));
}

void store_vtk_samples(const std::byte* data, VtkType type, bool big_endian, std::size_t components, Volume& volume,
                       std::vector<std::string>& notes) {
  const bool exact = convert_vtk_samples(data, type, big_endian, components, volume, 0, volume.voxel_count());
  note_vtk_conversion(type, components, exact, notes);
}

}  // namespace penumbra::io_detail
