// Legacy VTK files (.vtk) holding image data: "# vtk DataFile Version x.y", a title line, ASCII or
// BINARY (big-endian), DATASET STRUCTURED_POINTS with DIMENSIONS, SPACING (or ASPECT_RATIO) and
// ORIGIN, then POINT_DATA n and its first attribute, which must be SCALARS name type [components]
// followed by LOOKUP_TABLE. Component 0 of the scalars becomes the volume; whatever follows the values
// (further attributes, the METADATA block VTK 9 writes) is not read. The header is read line by line,
// as VTK writes it, so that the binary values can start right after the LOOKUP_TABLE line. A negative
// spacing reverses that axis, as with the .vti reader.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/text_fields.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/io/volume_placement.h"
#include "penumbra/data/io/vtk_image_data.h"

namespace penumbra {

namespace {

using io_detail::bytes_str;
using io_detail::printable;
using io_detail::upper;

// A header longer than this is not a legacy VTK header.
constexpr std::size_t kMaxHeaderLines = 64;
// The bytes read to find the header of a BINARY file (VTK writes header lines of at most 256 characters):
// the values after it are read by seeking, only those of the chosen slices.
constexpr std::size_t kLegacyHeaderBytes = std::size_t{64} << 10;
// The slices a whole BINARY file is read in at a time (this many bytes of values at most), converted into
// the volume as they come, so that the file's values are never held beside the volume.
constexpr std::size_t kBinarySlabBytes = std::size_t{16} << 20;

// The header's lines in order, each with where the next one starts.
class HeaderLines {
public:
  explicit HeaderLines(std::string_view text) : text_(text) {}
  // The next line (that is not blank, unless `any`); false at the end of the text.
  bool next(std::string_view& line, bool any = false) {
    while (pos_ < text_.size()) {
      if (++line_no_ > kMaxHeaderLines) throw Error("no POINT_DATA scalars in the first " + std::to_string(kMaxHeaderLines) + " lines");
      const std::size_t eol = std::min(text_.find('\n', pos_), text_.size());
      line = io_detail::trim(text_.substr(pos_, eol - pos_));
      pos_ = eol + 1;
      if (any || !line.empty()) return true;
    }
    return false;
  }
  std::size_t pos() const { return std::min(pos_, text_.size()); }  // where the next line starts
  std::string where() const { return "line " + std::to_string(line_no_); }

private:
  std::string_view text_;
  std::size_t pos_ = 0, line_no_ = 0;
};

struct LegacyHeader {
  bool binary = false;
  std::optional<std::array<std::int64_t, 3>> dims;
  std::array<double, 3> spacing{1, 1, 1}, origin{0, 0, 0};
  std::int64_t points = -1;
  std::string name;
  io_detail::VtkType type = io_detail::VtkType::UInt8;
  std::size_t components = 1;
  std::size_t data_start = 0;  // offset of the first value
};

// The numbers after a keyword: exactly `n` of them, finite.
template <std::size_t N>
std::array<double, N> numbers(const std::vector<std::string_view>& fields, const std::string& where) {
  if (fields.size() != N + 1)
    throw Error(where + ": " + upper(fields[0]) + " has " + std::to_string(fields.size() - 1) + " values (expected " + std::to_string(N) + ")");
  std::array<double, N> out{};
  for (std::size_t i = 0; i < N; ++i)
    if (!io_detail::parse_number(fields[i + 1], out[i]) || !std::isfinite(out[i]))
      throw Error(where + ": " + upper(fields[0]) + " value '" + printable(fields[i + 1], 40) + "' is not a finite number");
  return out;
}

std::int64_t count(std::string_view field, const std::string& what, std::int64_t max) {
  double v = 0;
  if (!io_detail::parse_number(field, v) || v != std::floor(v) || v < 1 || v > static_cast<double>(max))
    throw Error(what + " '" + printable(field, 40) + "' is not a whole number from 1 to " + std::to_string(max));
  return static_cast<std::int64_t>(v);
}

// `text`: the file, or (`prefix`) its first bytes, which must hold the header.
LegacyHeader parse_header(std::string_view text, bool prefix) {
  LegacyHeader h;
  HeaderLines lines(text);
  std::string_view line;
  if (!lines.next(line, true) || line.substr(0, 22) != "# vtk DataFile Version")
    throw Error("not a legacy VTK file (expected '# vtk DataFile Version x.y' on line 1)");
  lines.next(line, true);  // the title, whatever it says
  if (!lines.next(line) || (upper(line) != "ASCII" && upper(line) != "BINARY"))
    throw Error(lines.where() + ": '" + printable(line, 40) + "' (expected ASCII or BINARY)");
  h.binary = upper(line) == "BINARY";
  if (!lines.next(line)) throw Error("the file ends before its DATASET line");
  const auto dataset = io_detail::split_fields(line);
  if (dataset.size() != 2 || upper(dataset[0]) != "DATASET")
    throw Error(lines.where() + ": '" + printable(line, 60) + "' (expected DATASET STRUCTURED_POINTS)");
  if (upper(dataset[1]) != "STRUCTURED_POINTS")
    throw Error("DATASET " + printable(dataset[1], 40) +
                " is not supported (expected STRUCTURED_POINTS: image data; meshes and grids are not volumes)");
  while (lines.next(line)) {
    const auto fields = io_detail::split_fields(line);
    const std::string key = upper(fields[0]), where = lines.where();
    if (key == "DIMENSIONS") {
      const auto d = numbers<3>(fields, where);
      h.dims = std::array<std::int64_t, 3>{};
      for (std::size_t a = 0; a < 3; ++a) {
        if (d[a] < 1 || d[a] != std::floor(d[a]) || d[a] > 1e9)
          throw Error(where + ": DIMENSIONS value " + num(d[a]) + " is not a point count of at least 1");
        (*h.dims)[a] = static_cast<std::int64_t>(d[a]);
      }
    } else if (key == "SPACING" || key == "ASPECT_RATIO") {
      h.spacing = numbers<3>(fields, where);
    } else if (key == "ORIGIN") {
      h.origin = numbers<3>(fields, where);
    } else if (key == "POINT_DATA") {
      if (fields.size() != 2) throw Error(where + ": POINT_DATA needs one count");
      h.points = count(fields[1], where + ": POINT_DATA", std::int64_t{1} << 40);
    } else if (key == "SCALARS") {
      if (h.points < 0) throw Error(where + ": SCALARS before POINT_DATA (cell data is not supported)");
      if (fields.size() < 3 || fields.size() > 4) throw Error(where + ": expected SCALARS name type [components]");
      h.name = std::string(fields[1]);
      const auto type = io_detail::vtk_type_from_legacy(fields[2]);
      if (!type)
        throw Error(where + ": SCALARS type '" + printable(fields[2], 40) +
                    "' (expected unsigned_char, char, short, unsigned_short, int, unsigned_int, float or double)");
      h.type = *type;
      if (fields.size() == 4) h.components = static_cast<std::size_t>(count(fields[3], where + ": SCALARS components", 4));
      if (!lines.next(line) || upper(io_detail::split_fields(line)[0]) != "LOOKUP_TABLE")
        throw Error(lines.where() + ": expected LOOKUP_TABLE after SCALARS (VTK requires it; write LOOKUP_TABLE default)");
      h.data_start = lines.pos();
      return h;
    } else if (key == "CELL_DATA" || key == "FIELD" || h.points >= 0) {
      throw Error(where + ": " + printable(fields[0], 40) + (h.points >= 0 ? " as the first point attribute" : "") +
                  " is not supported (expected SCALARS in POINT_DATA)");
    } else {
      throw Error(where + ": unknown keyword '" + printable(fields[0], 40) +
                  "' (expected DIMENSIONS, SPACING, ORIGIN or POINT_DATA)");
    }
  }
  if (prefix) throw Error("no POINT_DATA SCALARS in the first " + bytes_str(text.size()) + " (a legacy VTK header is a few lines)");
  throw Error("the file ends before its POINT_DATA SCALARS");
}

// The file's first `bytes` bytes (at most its size, checked by the caller).
std::string read_file_start(const std::string& path, std::uint64_t bytes) {
  std::string text(static_cast<std::size_t>(bytes), '\0');
  std::ifstream in(path, std::ios::binary);
  if (!in || !in.read(text.data(), static_cast<std::streamsize>(bytes))) throw Error("cannot read the file");
  return text;
}

// Reads `bytes` bytes at `offset` of the open file (the caller checked they lie in it).
void read_at(std::ifstream& in, std::uint64_t offset, std::byte* out, std::size_t bytes) {
  in.seekg(static_cast<std::streamoff>(offset));
  if (!in || !in.read(reinterpret_cast<char*>(out), static_cast<std::streamsize>(bytes)))
    throw Error("cannot read " + bytes_str(bytes) + " of BINARY data at byte " + std::to_string(offset));
}

}  // namespace

Volume load_legacy_vtk_volume(const std::string& path, VolumeFileInfo* info) { return load_legacy_vtk_volume(path, info, nullptr, nullptr); }

Volume load_legacy_vtk_volume(const std::string& path, VolumeFileInfo* info, const SliceChooser* choose, WindowRead* read) {
  VolumeFileInfo local;
  VolumeFileInfo& out = info ? *info : local;
  out.format = "vtk";
  if (read) *read = WindowRead{};
  const std::uint64_t file_bytes = io_detail::regular_file_size(path);
  if (file_bytes == 0) throw Error("empty file (expected '# vtk DataFile Version x.y')");
  // The header first; an ASCII file is then read whole (its values have no fixed places), a BINARY one
  // only where its chosen values lie.
  const bool prefix = file_bytes > kLegacyHeaderBytes;
  std::string text = read_file_start(path, prefix ? kLegacyHeaderBytes : file_bytes);
  const LegacyHeader h = parse_header(text, prefix);
  if (!h.dims) throw Error("STRUCTURED_POINTS without DIMENSIONS");
  const auto& d = *h.dims;
  const std::string dims_text = std::to_string(d[0]) + "x" + std::to_string(d[1]) + "x" + std::to_string(d[2]);
  const std::size_t points = with_context("DIMENSIONS " + dims_text, [&] { return checked_voxel_count(d); });
  if (static_cast<std::uint64_t>(h.points) != points)
    throw Error("POINT_DATA " + std::to_string(h.points) + " but DIMENSIONS " + dims_text + " make " + std::to_string(points) + " points");

  const std::size_t values = points * h.components, size = io_detail::vtk_type_size(h.type);
  const std::string need = "DIMENSIONS " + dims_text + " x " + std::to_string(h.components) + " component(s) of " +
                           io_detail::vtk_type_name(h.type) + " need " + std::to_string(values) + " values";
  const std::uint64_t body_bytes = file_bytes - h.data_start;
  if (h.binary && body_bytes < values * size)
    throw Error("BINARY data has " + bytes_str(body_bytes) + " after the header but " + need + ", " + bytes_str(values * size) +
                " (truncated file or lying sizes)");

  // World = ORIGIN + index · SPACING (a negative SPACING reverses its axis), taken as it is (VTK's world
  // has no anatomical frame); the voxels are placed by it (volume_placement.h).
  std::array<double, 3> steps{}, origin{};
  for (std::size_t a = 0; a < 3; ++a) {
    if (h.spacing[a] == 0) throw Error("SPACING along axis " + std::to_string(a) + " is 0");
    steps[a] = h.spacing[a];
    origin[a] = h.origin[a];
  }
  const Affine affine = Affine::diagonal(steps, origin);
  const std::array<int, 3> dims{static_cast<int>(d[0]), static_cast<int>(d[1]), static_cast<int>(d[2])};
  const auto permutation = axis_permutation(affine);  // a diagonal: always a permutation
  const FileWindow window = file_window(choose, dims, permutation);
  const ScalarType type = io_detail::vtk_volume_type(h.type);
  const std::uint64_t slice_bytes = static_cast<std::uint64_t>(d[0]) * d[1] * h.components * size;

  if (h.binary) {
    // The file's slices [file_first, + count), a slab at a time, converted into the volume.
    Volume volume(type, {dims[0], dims[1], window.count}, {1, 1, 1}, {0, 0, 0}, VoxelFill::Uninitialized);
    std::ifstream in(path, std::ios::binary);
    if (!in) throw Error("cannot open the file");
    const int slab = static_cast<int>(std::clamp<std::uint64_t>(kBinarySlabBytes / slice_bytes, 1, static_cast<std::uint64_t>(window.count)));
    std::vector<std::byte> data(static_cast<std::size_t>(slice_bytes) * static_cast<std::size_t>(slab));
    const std::size_t slice_voxels = static_cast<std::size_t>(d[0]) * static_cast<std::size_t>(d[1]);
    bool exact = true;
    for (int first = 0; first < window.count; first += slab) {
      const int n = std::min(slab, window.count - first);
      read_at(in, h.data_start + (window.file_first + first) * slice_bytes, data.data(), static_cast<std::size_t>(n * slice_bytes));
      exact &= io_detail::convert_vtk_samples(data.data(), h.type, true, h.components, volume, static_cast<std::size_t>(first) * slice_voxels,
                                              static_cast<std::size_t>(n) * slice_voxels);
    }
    io_detail::note_vtk_conversion(h.type, h.components, exact, out.notes);
    if (read) read->bytes_read = static_cast<std::uint64_t>(window.count) * slice_bytes;
    if (window.in_part) return place_window(std::move(volume), affine, dims, *permutation, window, out);
    volume = keep_chosen_slices(place_volume(std::move(volume), affine, out), choose, window, read);
    volume.recompute_range();  // rejects NaN/inf voxels and gives the volume its range
    return volume;
  }

  if (prefix) text = read_file_start(path, file_bytes);
  if (read) read->bytes_read = file_bytes;
  const std::string_view body = std::string_view(text).substr(h.data_start);
  if (body.size() / 2 + 1 < values) throw Error("ASCII data has " + bytes_str(body.size()) + ", too short: " + need);
  std::vector<std::byte> data(values * size);
  with_context("SCALARS " + printable(h.name, 60), [&] { io_detail::parse_ascii_values(body, h.type, values, data.data()); });
  text = std::string{};
  Volume volume(type, dims, {1, 1, 1}, {0, 0, 0}, VoxelFill::Uninitialized);
  io_detail::store_vtk_samples(data.data(), h.type, false, h.components, volume, out.notes);
  volume = keep_chosen_slices(place_volume(std::move(volume), affine, out), choose, window, read);
  volume.recompute_range();
  return volume;
}

}  // namespace penumbra
