// What the two VTK image readers (vti_loader.cpp for XML ImageData, vtk_legacy_loader.cpp for legacy
// STRUCTURED_POINTS) share: VTK's scalar types and the Volume type each is kept in, ASCII values,
// the conversion of packed samples (either byte order, several components) into a Volume, and axis
// flips for files whose axes run backwards.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "penumbra/data/volume.h"

namespace penumbra::io_detail {

enum class VtkType { Int8, UInt8, Int16, UInt16, Int32, UInt32, Int64, UInt64, Float32, Float64 };

std::optional<VtkType> vtk_type_from_xml(std::string_view name);     // "Int16", "Float32", ...
std::optional<VtkType> vtk_type_from_legacy(std::string_view name);  // "short", "float", ... (any case)
std::size_t vtk_type_size(VtkType type);
const char* vtk_type_name(VtkType type);  // the XML name

// The Volume type samples are kept in: UInt8, Int16, UInt16 and Float32 as they are, Int8 widened to
// Int16 (exact), the 32/64-bit integers and Float64 converted to Float32.
ScalarType vtk_volume_type(VtkType type);

// Reads `count` whitespace-separated numbers of `type` from `text` into `out` (packed, native byte
// order); Error naming the value when one is missing, not a number, or outside the type. Returns the
// offset just after the last value read.
std::size_t parse_ascii_values(std::string_view text, VtkType type, std::size_t count, std::byte* out);

// Stores component 0 of `components`-component packed samples (big- or little-endian) into the volume,
// which has the size and the vtk_volume_type of the data; says in `notes` what a conversion did.
void store_vtk_samples(const std::byte* data, VtkType type, bool big_endian, std::size_t components, Volume& volume,
                       std::vector<std::string>& notes);
// The same for `count` samples stored from voxel `first` on (a slab of slices at a time); false when a
// conversion to float32 rounded a value (note_vtk_conversion then says so).
bool convert_vtk_samples(const std::byte* data, VtkType type, bool big_endian, std::size_t components, Volume& volume,
                         std::size_t first, std::size_t count);
void note_vtk_conversion(VtkType type, std::size_t components, bool exact, std::vector<std::string>& notes);

}  // namespace penumbra::io_detail
