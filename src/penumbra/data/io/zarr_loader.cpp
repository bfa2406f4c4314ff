// Zarr v2 stores (https://zarr.readthedocs.io/en/stable/spec/v2.html): one array (a folder with .zarray)
// or an OME-Zarr 0.4 image pyramid (a group whose .zattrs has "multiscales"; https://ngff.openmicroscopy.org/0.4/),
// one level of which is read. Chunks are decoded in parallel, each file read once; a chunk file that is
// missing holds the array's fill_value, as the spec says. Codecs: none, blosc (lz4, lz4hc, zstd, zlib,
// blosclz, snappy: whatever Debian's c-blosc decodes), zlib, gzip and zstd; a filter or another codec is
// refused by name. OME-Zarr 0.5 (Zarr v3, zarr.json) is refused with a message saying so.
//
// The pyramid's level: `level` (0 is the finest), or by default the finest whose voxels and macrocells
// (volume_held_bytes) fit the memory budget, without one a quarter of this machine's memory, so that a
// store far larger than memory opens at a level that fits (the note says which and how to choose another). Its scale and translation transformations give the
// voxels' spacing and origin; axes t and c before z, y, x are fixed (time 0, channel `channel`).
#include <blosc.h>
#include <unistd.h>
#include <zlib.h>
#include <zstd.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "penumbra/core/byte_size.h"
#include "penumbra/core/error.h"
#include "penumbra/core/parallel.h"
#include "penumbra/data/io/byte_order.h"
#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/text_fields.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/io/volume_placement.h"

namespace penumbra {

namespace {

namespace fs = std::filesystem;
using io_detail::bytes_str;
using io_detail::printable;

constexpr std::uint64_t kMaxMetadataBytes = 1u << 20;

nlohmann::json read_json(const fs::path& file) {
  std::error_code ec;
  const auto size = fs::file_size(file, ec);
  if (ec) throw Error(file.string() + ": cannot read (" + ec.message() + ")");
  if (size > kMaxMetadataBytes) throw Error(file.string() + ": " + bytes_str(size) + " of metadata (at most 1 MiB expected)");
  std::ifstream in(file, std::ios::binary);
  std::string text(static_cast<std::size_t>(size), '\0');
  if (!in.read(text.data(), static_cast<std::streamsize>(size))) throw Error(file.string() + ": cannot read");
  try {
    return nlohmann::json::parse(text);
  } catch (const nlohmann::json::exception& e) {
    throw Error(file.string() + ": not JSON (" + e.what() + ")");
  }
}

// The stored element type of a Zarr dtype string ("<u2", "|u1", ">f4").
struct DType {
  char kind = 'u';  // u, i, f
  int size = 1;
  bool big_endian = false;
};

DType parse_dtype(const nlohmann::json& j) {
  if (!j.is_string()) throw Error(".zarray: \"dtype\" is " + j.dump() + " (expected a string such as \"<u2\"; structured dtypes are not volumes)");
  const std::string s = j.get<std::string>();
  if (s.size() < 3 || (s[0] != '<' && s[0] != '>' && s[0] != '|')) throw Error(".zarray: dtype \"" + printable(s) + "\" (expected e.g. \"<u2\")");
  DType d;
  d.big_endian = s[0] == '>';
  d.kind = s[1];
  const std::string digits = s.substr(2);
  if (digits == "1") d.size = 1;
  else if (digits == "2") d.size = 2;
  else if (digits == "4") d.size = 4;
  else if (digits == "8") d.size = 8;
  else d.size = 0;
  const bool ok = (d.kind == 'u' || d.kind == 'i') ? d.size > 0 : (d.kind == 'f' && (d.size == 4 || d.size == 8));
  if (!ok) throw Error(".zarray: dtype \"" + printable(s) + "\" is not supported (expected an integer of 1-8 bytes, float32 or float64)");
  return d;
}

// Stored as: uint8, int16, uint16 and float32 as they are; int8 widened to int16; the rest as float32.
ScalarType storage_type(const DType& d) {
  if (d.kind == 'u' && d.size == 1) return ScalarType::UInt8;
  if (d.kind == 'u' && d.size == 2) return ScalarType::UInt16;
  if (d.kind == 'i' && d.size <= 2) return ScalarType::Int16;
  return ScalarType::Float32;
}

double element(const std::byte* p, const DType& d) {
  std::byte b[8];
  std::memcpy(b, p, static_cast<std::size_t>(d.size));
  if (d.big_endian && d.size > 1) std::reverse(b, b + d.size);
  switch (d.kind) {
    case 'u': {
      std::uint64_t v = 0;
      std::memcpy(&v, b, static_cast<std::size_t>(d.size));
      return static_cast<double>(v);
    }
    case 'i': {
      std::int64_t v = 0;
      std::memcpy(&v, b, static_cast<std::size_t>(d.size));
      const int shift = 64 - 8 * d.size;
      return static_cast<double>((v << shift) >> shift);  // sign-extended
    }
    default:
      if (d.size == 4) {
        float f = 0;
        std::memcpy(&f, b, 4);
        return f;
      }
      double x = 0;
      std::memcpy(&x, b, 8);
      return x;
  }
}

struct ZarrArray {
  fs::path folder;
  std::vector<std::int64_t> shape, chunks;
  DType dtype;
  nlohmann::json compressor;  // null or {"id": ...}
  double fill = 0;            // fill_value as a number (null: 0)
  bool fortran = false;       // order "F"
  char separator = '.';
};

ZarrArray read_array_metadata(const fs::path& folder) {
  const fs::path meta = folder / ".zarray";
  const nlohmann::json j = read_json(meta);
  return with_context(meta.string(), [&] {
    if (!j.is_object()) throw Error("expected a JSON object");
    if (j.value("zarr_format", 0) != 2) throw Error("zarr_format " + j.value("zarr_format", nlohmann::json()).dump() + " (expected 2)");
    ZarrArray a;
    a.folder = folder;
    for (const char* key : {"shape", "chunks"}) {
      if (!j.contains(key) || !j[key].is_array() || j[key].empty()) throw Error(std::string("\"") + key + "\" missing or not a list");
      for (const auto& v : j[key]) {
        if (!v.is_number_integer() || v.get<std::int64_t>() < (std::string(key) == "shape" ? 0 : 1) || v.get<std::int64_t>() > (std::int64_t{1} << 40))
          throw Error(std::string("\"") + key + "\" holds " + v.dump() + " (expected whole numbers)");
        (std::string(key) == "shape" ? a.shape : a.chunks).push_back(v.get<std::int64_t>());
      }
    }
    if (a.shape.size() != a.chunks.size()) throw Error("\"shape\" and \"chunks\" have different lengths");
    a.dtype = parse_dtype(j.value("dtype", nlohmann::json()));
    a.compressor = j.value("compressor", nlohmann::json());
    if (j.contains("filters") && !j["filters"].is_null() && !j["filters"].empty())
      throw Error("filters " + j["filters"].dump() + " are not supported (penumbra decodes a compressor only)");
    const std::string order = j.value("order", std::string("C"));
    if (order != "C" && order != "F") throw Error("order \"" + printable(order) + "\" (expected \"C\" or \"F\")");
    a.fortran = order == "F";
    const std::string sep = j.value("dimension_separator", std::string("."));
    if (sep != "." && sep != "/") throw Error("dimension_separator \"" + printable(sep) + "\" (expected \".\" or \"/\")");
    a.separator = sep[0];
    const nlohmann::json& fill = j.value("fill_value", nlohmann::json());
    if (fill.is_number()) a.fill = fill.get<double>();
    else if (fill.is_string() && fill.get<std::string>() == "NaN") a.fill = std::numeric_limits<double>::quiet_NaN();
    else if (!fill.is_null()) throw Error("fill_value " + fill.dump() + " (expected a number, \"NaN\" or null)");
    if (a.compressor.is_object()) {
      const std::string id = a.compressor.value("id", std::string());
      if (id != "blosc" && id != "zlib" && id != "gzip" && id != "zstd")
        throw Error("compressor \"" + printable(id) + "\" is not supported (expected blosc, zlib, gzip, zstd or none)");
    } else if (!a.compressor.is_null()) {
      throw Error("compressor " + a.compressor.dump() + " (expected null or {\"id\": ...})");
    }
    return a;
  });
}

std::vector<std::byte> read_file(const fs::path& file) {
  std::ifstream in(file, std::ios::binary | std::ios::ate);
  if (!in) throw Error("cannot read");
  const auto size = static_cast<std::size_t>(in.tellg());
  std::vector<std::byte> bytes(size);
  in.seekg(0);
  if (size > 0 && !in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(size))) throw Error("cannot read");
  return bytes;
}

void inflate_all(const std::vector<std::byte>& in, std::vector<std::byte>& out, bool gzip) {
  z_stream z{};
  if (inflateInit2(&z, gzip ? 16 + MAX_WBITS : MAX_WBITS) != Z_OK) throw Error("zlib could not start");
  z.next_in = reinterpret_cast<Bytef*>(const_cast<std::byte*>(in.data()));
  z.avail_in = static_cast<uInt>(in.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  const int status = inflate(&z, Z_FINISH);
  const std::size_t produced = out.size() - z.avail_out;
  inflateEnd(&z);
  if (status != Z_STREAM_END || produced != out.size())
    throw Error(std::string(gzip ? "gzip" : "zlib") + " data is corrupt or holds " + (status == Z_STREAM_END ? std::to_string(produced) : "other than") +
                " bytes (the chunk needs " + bytes_str(out.size()) + ")");
}

// The chunk's bytes as stored before compression: exactly `bytes` of them.
std::vector<std::byte> decode_chunk(const ZarrArray& a, const std::vector<std::byte>& stored, std::size_t bytes) {
  std::vector<std::byte> out(bytes);
  const std::string id = a.compressor.is_object() ? a.compressor.value("id", std::string()) : std::string();
  if (id.empty()) {
    if (stored.size() != bytes) throw Error(bytes_str(stored.size()) + " (an uncompressed chunk of " + bytes_str(bytes) + " expected)");
    std::memcpy(out.data(), stored.data(), bytes);
  } else if (id == "blosc") {
    std::size_t nbytes = 0, cbytes = 0, block = 0;
    if (stored.size() < BLOSC_MIN_HEADER_LENGTH) throw Error("a blosc chunk shorter than its header");
    blosc_cbuffer_sizes(stored.data(), &nbytes, &cbytes, &block);
    if (nbytes != bytes || cbytes != stored.size())
      throw Error("the blosc header says " + bytes_str(nbytes) + " from " + bytes_str(cbytes) + " (the chunk needs " + bytes_str(bytes) +
                  " from the file's " + bytes_str(stored.size()) + ")");
    const int n = blosc_decompress_ctx(stored.data(), out.data(), bytes, 1);
    if (n < 0 || static_cast<std::size_t>(n) != bytes) throw Error("blosc could not decode the chunk (corrupt, or a codec c-blosc lacks)");
  } else if (id == "zlib" || id == "gzip") {
    inflate_all(stored, out, id == "gzip");
  } else {  // zstd
    const unsigned long long size = ZSTD_getFrameContentSize(stored.data(), stored.size());
    if (size == ZSTD_CONTENTSIZE_ERROR) throw Error("not a zstd frame");
    if (size != ZSTD_CONTENTSIZE_UNKNOWN && size != bytes)
      throw Error("the zstd frame holds " + bytes_str(size) + " (the chunk needs " + bytes_str(bytes) + ")");
    const std::size_t n = ZSTD_decompress(out.data(), bytes, stored.data(), stored.size());
    if (ZSTD_isError(n) || n != bytes) throw Error(std::string("zstd could not decode the chunk: ") + (ZSTD_isError(n) ? ZSTD_getErrorName(n) : "short"));
  }
  return out;
}

// The physical memory of this machine in bytes (0 when unknown).
std::uint64_t physical_memory() {
  const long pages = ::sysconf(_SC_PHYS_PAGES), page = ::sysconf(_SC_PAGESIZE);
  return pages > 0 && page > 0 ? static_cast<std::uint64_t>(pages) * static_cast<std::uint64_t>(page) : 0;
}

struct Level {
  std::string path;
  std::array<double, 3> scale{1, 1, 1}, translation{0, 0, 0};  // x, y, z
};

// A list of coordinateTransformations applied to (x, y, z) spacing and origin.
void apply_transforms(const nlohmann::json& list, std::size_t n_axes, Level& level, const std::string& where) {
  if (list.is_null()) return;
  if (!list.is_array()) throw Error(where + ": coordinateTransformations is not a list");
  for (const auto& t : list) {
    const std::string type = t.value("type", std::string());
    if (type == "identity") continue;
    if (type != "scale" && type != "translation")
      throw Error(where + ": a transformation of type \"" + printable(type) + "\" (expected scale or translation)");
    if (t.contains("path")) throw Error(where + ": a " + type + " stored in a file (\"path\") is not supported");
    const nlohmann::json& v = t.value(type, nlohmann::json());
    if (!v.is_array() || v.size() != n_axes || !std::all_of(v.begin(), v.end(), [](const nlohmann::json& x) { return x.is_number(); }))
      throw Error(where + ": the " + type + " must hold " + std::to_string(n_axes) + " numbers, one per axis");
    for (int a = 0; a < 3; ++a) {
      const double x = v[n_axes - 1 - static_cast<std::size_t>(a)].get<double>();  // the last axis is x
      if (type == "scale") {
        if (!(x > 0) || !std::isfinite(x)) throw Error(where + ": a scale of " + nlohmann::json(x).dump() + " (expected positive)");
        level.scale[a] *= x;
        level.translation[a] *= x;
      } else {
        level.translation[a] += x;
      }
    }
  }
}

struct Pyramid {
  std::vector<std::string> axes;      // names, e.g. t c z y x
  std::vector<std::string> units;     // per axis ("" when none)
  std::vector<Level> levels;          // finest first
};

Pyramid read_multiscales(const nlohmann::json& attrs, const fs::path& where_file) {
  const std::string where = where_file.string();
  const nlohmann::json& ms = attrs["multiscales"];
  if (!ms.is_array() || ms.empty() || !ms[0].is_object()) throw Error(where + ": \"multiscales\" is not a list of images");
  const nlohmann::json& m = ms[0];
  Pyramid p;
  const nlohmann::json& axes = m.value("axes", nlohmann::json());
  if (axes.is_array()) {
    for (const auto& a : axes) {
      if (a.is_string()) p.axes.push_back(a.get<std::string>()), p.units.emplace_back();
      else if (a.is_object() && a.contains("name") && a["name"].is_string())
        p.axes.push_back(a["name"].get<std::string>()), p.units.push_back(a.value("unit", std::string()));
      else throw Error(where + ": an axis " + a.dump() + " (expected a name or {\"name\": ...})");
    }
  }
  const nlohmann::json& datasets = m.value("datasets", nlohmann::json());
  if (!datasets.is_array() || datasets.empty()) throw Error(where + ": the image has no \"datasets\" (its levels)");
  for (const auto& d : datasets) {
    if (!d.is_object() || !d.contains("path") || !d["path"].is_string()) throw Error(where + ": a dataset without a \"path\"");
    Level level;
    level.path = d["path"].get<std::string>();
    if (level.path.empty() || level.path.find("..") != std::string::npos || level.path[0] == '/')
      throw Error(where + ": dataset path \"" + printable(level.path) + "\" (expected a folder inside the store)");
    const std::size_t n = p.axes.empty() ? 3 : p.axes.size();
    apply_transforms(d.value("coordinateTransformations", nlohmann::json()), n, level, where + ", dataset " + level.path);
    apply_transforms(m.value("coordinateTransformations", nlohmann::json()), n, level, where + ", multiscale");
    p.levels.push_back(level);
  }
  return p;
}

// The spatial part of the array (its last three axes) and the fixed indices of the others.
struct Selection {
  std::array<std::int64_t, 3> dims{};    // x, y, z
  std::vector<std::int64_t> fixed;       // per leading axis: the index read
};

}  // namespace

bool is_zarr_store(const std::string& path) {
  std::error_code ec;
  const fs::path p(path);
  if (!fs::is_directory(p, ec)) return false;
  for (const char* name : {".zarray", ".zgroup", ".zattrs", "zarr.json"})
    if (fs::exists(p / name, ec)) return true;
  return false;
}

Volume load_zarr_volume(const std::string& path, int level_choice, int channel, VolumeFileInfo* info, std::uint64_t memory_budget,
                        const SliceChooser* choose, WindowRead* read) {
  VolumeFileInfo local;
  VolumeFileInfo& out = info ? *info : local;
  out.format = "zarr";
  const fs::path root(path);
  std::error_code ec;
  if (fs::exists(root / "zarr.json", ec))
    throw Error("a Zarr v3 store (zarr.json: OME-Zarr 0.5); penumbra reads Zarr v2 (OME-Zarr 0.4). Convert it with "
                "python3-zarr, or ask for v3");
  Pyramid pyramid;
  fs::path array_folder = root;
  Level chosen;
  int level_index = 0;
  if (fs::exists(root / ".zattrs", ec) && !fs::exists(root / ".zarray", ec)) {
    const nlohmann::json attrs = read_json(root / ".zattrs");
    if (!attrs.is_object() || !attrs.contains("multiscales"))
      throw Error("a Zarr group without \"multiscales\" in its .zattrs (expected an OME-Zarr image, or the folder of one array)");
    pyramid = read_multiscales(attrs, root / ".zattrs");
  }
  if (!pyramid.levels.empty()) {
    const int n = static_cast<int>(pyramid.levels.size());
    if (level_choice >= n) throw Error("'level' " + std::to_string(level_choice) + ": the pyramid has " + std::to_string(n) + " levels (0 to " + std::to_string(n - 1) + ")");
    if (level_choice >= 0) {
      level_index = level_choice;
    } else {  // the finest level that fits the budget, or a quarter of the machine's memory
      const std::uint64_t budget = memory_budget > 0 ? memory_budget : physical_memory() / 4;
      const std::string what = memory_budget > 0 ? "the memory budget (" + byte_size_string(budget) + ")"
                                                 : "a quarter of this machine's memory (" + byte_size_string(budget) + ")";
      level_index = -1;
      std::uint64_t coarsest = 0;
      for (int l = 0; l < n; ++l) {
        const ZarrArray a = read_array_metadata(root / pyramid.levels[static_cast<std::size_t>(l)].path);
        double voxels = 1;
        std::array<std::int64_t, 3> dims{1, 1, 1};  // x, y, z
        for (std::size_t k = a.shape.size() >= 3 ? a.shape.size() - 3 : 0, axis = 2; k < a.shape.size(); ++k, --axis) {
          voxels *= static_cast<double>(a.shape[k]);
          dims[axis] = a.shape[k];
        }
        const double bytes = voxels > 1e18 ? 1e19 : static_cast<double>(volume_held_bytes(dims, storage_type(a.dtype)));
        coarsest = static_cast<std::uint64_t>(std::min(bytes, 1e19));
        if (budget == 0 || bytes <= static_cast<double>(budget)) {
          level_index = l;
          break;
        }
      }
      if (level_index < 0) {
        if (memory_budget > 0)
          throw Error("no level of the pyramid fits " + what + ": the coarsest, " + std::to_string(n - 1) + ", holds " +
                      byte_size_string(coarsest) + " (raise memory_budget, or choose 'level')");
        level_index = n - 1;
      }
      if (level_index > 0 || memory_budget > 0)
        out.notes.push_back("level " + std::to_string(level_index) + " of " + std::to_string(n) + " loaded: the finest whose voxels fit " + what +
                            "; 'level' chooses another");
    }
    std::string sizes;
    for (int l = 0; l < n; ++l) {
      const ZarrArray la = read_array_metadata(root / pyramid.levels[static_cast<std::size_t>(l)].path);
      std::string shape;
      for (std::size_t k = la.shape.size(); k-- > (la.shape.size() >= 3 ? la.shape.size() - 3 : 0);)
        shape += (shape.empty() ? "" : "x") + std::to_string(la.shape[k]);
      sizes += (l ? ", " : "") + std::to_string(l) + ": " + shape;
    }
    out.notes.push_back("pyramid levels (x y z voxels) " + sizes);
    chosen = pyramid.levels[static_cast<std::size_t>(level_index)];
    array_folder = root / chosen.path;
    out.notes.push_back("OME-Zarr level " + std::to_string(level_index) + " of " + std::to_string(n) + " (\"" + chosen.path + "\")");
  } else if (level_choice > 0) {
    throw Error("'level' " + std::to_string(level_choice) + ": this Zarr array is not a pyramid (one level, 0)");
  }
  const ZarrArray a = read_array_metadata(array_folder);
  const std::size_t rank = a.shape.size();
  if (rank < 3) throw Error(array_folder.string() + ": a " + std::to_string(rank) + "-D array (expected 3 spatial axes, z y x, last)");
  if (!pyramid.axes.empty() && pyramid.axes.size() != rank)
    throw Error("the image names " + std::to_string(pyramid.axes.size()) + " axes, its array at \"" + chosen.path + "\" has " + std::to_string(rank));

  Selection sel;
  for (int a3 = 0; a3 < 3; ++a3) sel.dims[a3] = a.shape[rank - 1 - static_cast<std::size_t>(a3)];
  int channels = 1;
  for (std::size_t k = 0; k + 3 < rank; ++k) {
    const std::string name = pyramid.axes.empty() ? "" : pyramid.axes[k];
    std::int64_t index = 0;
    if (name == "c") {
      channels = static_cast<int>(a.shape[k]);
      index = channel < 0 ? 0 : channel;
      if (index >= a.shape[k]) throw Error("'channel' " + std::to_string(index) + ": the image has " + std::to_string(a.shape[k]) + " channels");
      out.channels = channels;
      out.channel = static_cast<int>(index);
    } else if (a.shape[k] > 1) {
      out.notes.push_back("axis " + (name.empty() ? std::to_string(k) : "'" + name + "'") + " has " + std::to_string(a.shape[k]) + " entries: the first is loaded");
    }
    if (a.shape[k] == 0) throw Error("axis " + std::to_string(k) + " of the array is empty");
    sel.fixed.push_back(index);
  }
  if (channel >= 0 && channels == 1 && std::find(pyramid.axes.begin(), pyramid.axes.end(), "c") == pyramid.axes.end())
    throw Error("'channel' " + std::to_string(channel) + ": the image has no channel axis");
  const std::size_t count = with_context("shape", [&] { return checked_voxel_count(sel.dims); });
  (void)count;
  for (int a3 = 0; a3 < 3; ++a3)
    if (sel.dims[a3] > std::numeric_limits<int>::max()) throw Error("an axis of " + std::to_string(sel.dims[a3]) + " voxels is too long");

  const ScalarType type = storage_type(a.dtype);
  // A window (one rank's brick, a slab of `penumbra convert`): the chosen slices only, from the chunks
  // that hold them. The level's scale keeps z's direction (a negative one flips it): read whole and cut.
  if (read) *read = WindowRead{};
  const std::array<int, 3> whole_dims{static_cast<int>(sel.dims[0]), static_cast<int>(sel.dims[1]), static_cast<int>(sel.dims[2])};
  const SliceRange chosen_slices = choose ? checked_slices(*choose, whole_dims) : SliceRange{0, whole_dims[2]};
  const bool windowed = choose && chosen.scale[2] > 0;
  const SliceRange slices = windowed ? chosen_slices : SliceRange{0, whole_dims[2]};
  std::atomic<std::uint64_t> bytes_read{0};
  Volume volume(type, {whole_dims[0], whole_dims[1], slices.count}, {1, 1, 1}, {0, 0, 0}, VoxelFill::Uninitialized);
  // the chunk grid over the spatial axes (x, y, z), the leading axes fixed to the chunk holding the index
  std::array<std::int64_t, 3> chunk{}, grid{};
  for (int a3 = 0; a3 < 3; ++a3) {
    chunk[a3] = a.chunks[rank - 1 - static_cast<std::size_t>(a3)];
    grid[a3] = (sel.dims[a3] + chunk[a3] - 1) / chunk[a3];
  }
  std::int64_t chunk_elements = 1;
  for (const auto c : a.chunks) {
    if (chunk_elements > (std::int64_t{1} << 40) / c) throw Error(array_folder.string() + ": chunks of over 2^40 elements");
    chunk_elements *= c;
  }
  const std::size_t chunk_bytes = static_cast<std::size_t>(chunk_elements) * static_cast<std::size_t>(a.dtype.size);
  if (chunk_bytes > (std::size_t{1} << 31)) throw Error(array_folder.string() + ": chunks of " + bytes_str(chunk_bytes) + " (at most 2 GiB)");
  // strides of an element inside a chunk, per array axis, in C or F order
  std::vector<std::int64_t> stride(rank);
  {
    std::int64_t s = 1;
    if (a.fortran)
      for (std::size_t k = 0; k < rank; ++k) stride[k] = s, s *= a.chunks[k];
    else
      for (std::size_t k = rank; k-- > 0;) stride[k] = s, s *= a.chunks[k];
  }
  std::int64_t lead_offset = 0;  // the element offset of the fixed leading indices inside their chunk
  std::string lead_key;
  for (std::size_t k = 0; k + 3 < rank; ++k) {
    lead_offset += (sel.fixed[k] % a.chunks[k]) * stride[k];
    lead_key += std::to_string(sel.fixed[k] / a.chunks[k]) + a.separator;
  }
  const std::int64_t z_first = slices.first, z_end = static_cast<std::int64_t>(slices.first) + slices.count;
  const std::int64_t chunk_z0 = z_first / chunk[2], chunk_z1 = z_end > 0 ? (z_end - 1) / chunk[2] + 1 : 0;
  const std::size_t n_chunks = static_cast<std::size_t>(grid[0] * grid[1] * (chunk_z1 - chunk_z0));
  std::atomic<std::size_t> missing{0};
  std::mutex failure_mutex;
  std::optional<std::string> failure;
  volume.with_voxel_type([&](auto t) {
    using T = decltype(t);
    T* dst = volume.data_as<T>();
    const bool direct = !a.fortran && !a.dtype.big_endian && a.dtype.size == static_cast<int>(sizeof(T)) &&
                        (std::is_same_v<T, float> ? a.dtype.kind == 'f' : std::is_same_v<T, std::int16_t> ? a.dtype.kind == 'i' : a.dtype.kind == 'u');
    const auto store = [&](std::size_t index, double v) {
      if constexpr (std::is_same_v<T, float>) dst[index] = static_cast<float>(v);
      else dst[index] = static_cast<T>(v);
    };
    parallel_for(n_chunks, [&](std::size_t c0, std::size_t c1) {
      for (std::size_t c = c0; c < c1; ++c) {
        const std::array<std::int64_t, 3> ci{static_cast<std::int64_t>(c) % grid[0], static_cast<std::int64_t>(c) / grid[0] % grid[1],
                                             chunk_z0 + static_cast<std::int64_t>(c) / (grid[0] * grid[1])};
        const std::string key = lead_key + std::to_string(ci[2]) + a.separator + std::to_string(ci[1]) + a.separator + std::to_string(ci[0]);
        const fs::path file = a.folder / key;
        try {
          std::error_code fec;
          std::vector<std::byte> bytes;
          const bool present = fs::is_regular_file(file, fec);
          if (present) {
            std::vector<std::byte> stored = read_file(file);
            bytes_read += stored.size();
            bytes = decode_chunk(a, std::move(stored), chunk_bytes);
          } else {
            ++missing;
          }
          const std::int64_t x0 = ci[0] * chunk[0], x1 = std::min(sel.dims[0], (ci[0] + 1) * chunk[0]);
          for (std::int64_t z = std::max(z_first, ci[2] * chunk[2]); z < std::min(z_end, (ci[2] + 1) * chunk[2]); ++z)
            for (std::int64_t y = ci[1] * chunk[1]; y < std::min(sel.dims[1], (ci[1] + 1) * chunk[1]); ++y) {
              const std::size_t row = static_cast<std::size_t>(((z - z_first) * sel.dims[1] + y) * sel.dims[0]);
              if (!present) {
                for (std::int64_t x = x0; x < x1; ++x) store(row + static_cast<std::size_t>(x), a.fill);
                continue;
              }
              const std::int64_t first = lead_offset + (z - ci[2] * chunk[2]) * stride[rank - 3] + (y - ci[1] * chunk[1]) * stride[rank - 2];
              if (direct) {  // the stored type, little-endian, C order: the row's voxels lie side by side
                std::memcpy(dst + row + static_cast<std::size_t>(x0), bytes.data() + first * a.dtype.size,
                            static_cast<std::size_t>(x1 - x0) * sizeof(T));
                continue;
              }
              for (std::int64_t x = x0; x < x1; ++x)
                store(row + static_cast<std::size_t>(x), element(bytes.data() + (first + (x - x0) * stride[rank - 1]) * a.dtype.size, a.dtype));
            }
        } catch (const std::exception& e) {
          const std::lock_guard lock(failure_mutex);
          if (!failure) failure = "chunk " + file.string() + ": " + e.what();
        }
      }
    });
  });
  if (failure) throw Error(*failure);
  if (missing > 0)
    out.notes.push_back(std::to_string(missing.load()) + " of " + std::to_string(n_chunks) + " chunks are not stored: they hold the fill value " +
                        nlohmann::json(a.fill).dump());
  const bool kept = (a.dtype.kind == 'u' && a.dtype.size <= 2) || (a.dtype.kind == 'i' && a.dtype.size == 2) || (a.dtype.kind == 'f' && a.dtype.size == 4);
  if (!kept)
    out.notes.push_back("stored as " + to_string(type) + " (the file's " + std::string(a.dtype.kind == 'f' ? "float" : a.dtype.kind == 'u' ? "uint" : "int") +
                        std::to_string(8 * a.dtype.size) + ")");
  std::string unit;
  if (!pyramid.units.empty() && !pyramid.units.back().empty()) unit = pyramid.units.back();
  if (!unit.empty()) out.notes.push_back("spacing in " + unit + " (the image's unit)");
  const Affine affine = Affine::diagonal(chosen.scale, chosen.translation);
  volume = place_volume(std::move(volume), affine, out);  // a window's origin is still the whole grid's here
  if (level_index > 0) {  // opacities refer to the finest level's voxel, so that every level shows the same matter
    const auto& finest = pyramid.levels.front().scale;
    volume.set_opacity_length(static_cast<float>(std::min({std::abs(finest[0]), std::abs(finest[1]), std::abs(finest[2])})));
  }
  volume.recompute_range();  // rejects NaN voxels (a NaN fill value of missing chunks too) and gives the range
  if (read) read->bytes_read = bytes_read.load();
  if (choose && !windowed && chosen_slices.count < whole_dims[2]) {
    if (read) read->whole = true;
    volume = volume.window_z(chosen_slices.first, chosen_slices.count);
    volume.recompute_range();
  } else if (windowed && slices.count < whole_dims[2]) {
    volume.set_window(slices.first, whole_dims[2]);
  }
  return volume;
}

}  // namespace penumbra
