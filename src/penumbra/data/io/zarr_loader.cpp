// Zarr stores, v2 and v3 (zarr_array.h: metadata, chunk keys, shards and codecs): one array (a folder
// with .zarray, or zarr.json of an array) or an OME-Zarr image pyramid — 0.4 on Zarr v2 (a group whose
// .zattrs has "multiscales"; https://ngff.openmicroscopy.org/0.4/) or 0.5 on Zarr v3 (a group whose
// zarr.json has attributes.ome.multiscales; https://ngff.openmicroscopy.org/0.5/) — one level of which is
// read. Chunks are decoded in parallel, each read once; a chunk that is not stored holds the array's
// fill_value, as the spec says.
//
// The pyramid's level: `level` (0 is the finest), or by default the finest whose voxels and macrocells
// (volume_held_bytes) fit the memory budget, without one a quarter of this machine's memory, so that a
// store far larger than memory opens at a level that fits (the note says which and how to choose another). Its scale and translation transformations give the
// voxels' spacing and origin; axes t and c before z, y, x are fixed (time 0, channel `channel`).
#include <unistd.h>

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
#include "penumbra/core/cancel.h"
#include "penumbra/core/parallel.h"
#include "penumbra/data/io/byte_order.h"
#include "penumbra/data/io/file_checks.h"
#include "penumbra/data/io/text_fields.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/io/zarr_array.h"
#include "penumbra/data/io/volume_placement.h"

namespace penumbra {

namespace {

namespace fs = std::filesystem;
using io_detail::bytes_str;
using io_detail::printable;

using io_detail::ZarrArray;
using DType = io_detail::ZarrDType;

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
    const std::string type = io_detail::json_string(t, "type", "");
    if (type == "identity") continue;
    if (type != "scale" && type != "translation")
      throw Error(where + ": a transformation of type \"" + printable(type) + "\" (expected scale or translation)");
    if (t.contains("path")) throw Error(where + ": a " + type + " stored in a file (\"path\") is not supported");
    const nlohmann::json& v = io_detail::json_field(t, type.c_str());
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
  const nlohmann::json& axes = io_detail::json_field(m, "axes");
  if (axes.is_array()) {
    for (const auto& a : axes) {
      if (a.is_string()) p.axes.push_back(a.get<std::string>()), p.units.emplace_back();
      else if (a.is_object() && a.contains("name") && a["name"].is_string())
        p.axes.push_back(a["name"].get<std::string>()), p.units.push_back(io_detail::json_string(a, "unit", ""));
      else throw Error(where + ": an axis " + a.dump() + " (expected a name or {\"name\": ...})");
    }
  }
  const nlohmann::json& datasets = io_detail::json_field(m, "datasets");
  if (!datasets.is_array() || datasets.empty()) throw Error(where + ": the image has no \"datasets\" (its levels)");
  for (const auto& d : datasets) {
    if (!d.is_object() || !d.contains("path") || !d["path"].is_string()) throw Error(where + ": a dataset without a \"path\"");
    Level level;
    level.path = d["path"].get<std::string>();
    if (level.path.empty() || level.path.find("..") != std::string::npos || level.path[0] == '/')
      throw Error(where + ": dataset path \"" + printable(level.path) + "\" (expected a folder inside the store)");
    const std::size_t n = p.axes.empty() ? 3 : p.axes.size();
    apply_transforms(io_detail::json_field(d, "coordinateTransformations"), n, level, where + ", dataset " + level.path);
    apply_transforms(io_detail::json_field(m, "coordinateTransformations"), n, level, where + ", multiscale");
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

namespace {

// The OME-Zarr pyramid at `root` (0.5: zarr.json's attributes.ome; 0.4: .zattrs); no levels when
// `root` is the folder of one array; Error for a group without "multiscales".
Pyramid read_pyramid(const fs::path& root) {
  std::error_code ec;
  if (fs::exists(root / "zarr.json", ec)) {  // Zarr v3: an array, or a group (an OME-Zarr 0.5 image)
    const nlohmann::json node = io_detail::read_zarr_json(root / "zarr.json");
    if (!node.is_object()) throw Error((root / "zarr.json").string() + ": expected a JSON object");
    if (io_detail::json_string(node, "node_type", "") != "group") return {};
    const nlohmann::json& attrs = io_detail::json_field(node, "attributes");
    const nlohmann::json& ome = attrs.is_object() && attrs.contains("ome") ? attrs["ome"] : attrs;
    if (!ome.is_object() || !ome.contains("multiscales"))
      throw Error("a Zarr group without \"multiscales\" in its zarr.json attributes (expected an OME-Zarr 0.5 image, or the folder of one array)");
    return read_multiscales(ome, root / "zarr.json");
  }
  if (fs::exists(root / ".zattrs", ec) && !fs::exists(root / ".zarray", ec)) {
    const nlohmann::json attrs = io_detail::read_zarr_json(root / ".zattrs");
    if (!attrs.is_object() || !attrs.contains("multiscales"))
      throw Error("a Zarr group without \"multiscales\" in its .zattrs (expected an OME-Zarr image, or the folder of one array)");
    return read_multiscales(attrs, root / ".zattrs");
  }
  return {};
}

// Voxels [lo, hi) of a level along x, y, z.
struct IndexBox {
  std::array<std::int64_t, 3> lo{}, hi{};
};

// load_zarr_volume, or with `box` that box of the level `level_choice` names, placed where it lies (not a
// window of the whole grid).
Volume load_zarr(const std::string& path, int level_choice, int channel, VolumeFileInfo* info, std::uint64_t memory_budget,
                 const SliceChooser* choose, WindowRead* read, const IndexBox* box, const HeldBox* held = nullptr) {
  VolumeFileInfo local;
  VolumeFileInfo& out = info ? *info : local;
  out.format = "zarr";
  const fs::path root(path);
  fs::path array_folder = root;
  Level chosen;
  int level_index = 0;
  const Pyramid pyramid = read_pyramid(root);
  if (!pyramid.levels.empty()) {
    const int n = static_cast<int>(pyramid.levels.size());
    if (level_choice >= n) throw Error("'level' " + std::to_string(level_choice) + ": the pyramid has " + std::to_string(n) + " levels (0 to " + std::to_string(n - 1) + ")");
    if (level_choice >= 0) {
      level_index = level_choice;
    } else {  // the finest level that fits the budget, or a quarter of the machine's memory
      const std::uint64_t budget = memory_budget > 0 ? memory_budget : default_pyramid_budget();
      const std::string what = memory_budget > 0 ? "the memory budget (" + byte_size_string(budget) + ")"
                                                 : "a quarter of this machine's memory (" + byte_size_string(budget) + ")";
      level_index = -1;
      std::uint64_t coarsest = 0;
      for (int l = 0; l < n; ++l) {
        const ZarrArray a = io_detail::read_zarr_array(root / pyramid.levels[static_cast<std::size_t>(l)].path);
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
      const ZarrArray la = io_detail::read_zarr_array(root / pyramid.levels[static_cast<std::size_t>(l)].path);
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
  const ZarrArray a = io_detail::read_zarr_array(array_folder);
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
  // the voxels read: a box, the chosen slices, or the whole level
  IndexBox want{{0, 0, slices.first}, {sel.dims[0], sel.dims[1], std::int64_t{slices.first} + slices.count}};
  if (box) {
    for (int a3 = 0; a3 < 3; ++a3)
      if (box->lo[a3] < 0 || box->hi[a3] > sel.dims[a3] || box->lo[a3] >= box->hi[a3])
        throw Error("voxels " + std::to_string(box->lo[a3]) + " to " + std::to_string(box->hi[a3] - 1) + " along axis " + std::to_string(a3) +
                    " of a level of " + std::to_string(sel.dims[a3]));
    if (chosen.scale[0] <= 0 || chosen.scale[1] <= 0 || chosen.scale[2] <= 0) throw Error("a box of a level whose scale reverses an axis");
    want = *box;
  }
  const std::array<std::int64_t, 3> want_dims{want.hi[0] - want.lo[0], want.hi[1] - want.lo[1], want.hi[2] - want.lo[2]};
  std::atomic<std::uint64_t> bytes_read{0}, bytes_reused{0};
  if (held && (!box || !held->voxels || held->voxels->type() != type || held->voxels->is_bricked())) held = nullptr;
  // the held box's own voxels when it gives them up (moved in place: the chunks inside it are there already)
  std::optional<Volume> taken = box ? take_held_storage(held, type, want.lo, want.hi) : std::nullopt;
  const bool in_place = taken.has_value();
  Volume volume = in_place ? std::move(*taken)
                           : Volume(type, {static_cast<int>(want_dims[0]), static_cast<int>(want_dims[1]), static_cast<int>(want_dims[2])}, {1, 1, 1},
                                    {0, 0, 0}, VoxelFill::Uninitialized);
  if (in_place) volume.set_opacity_length(0);
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
  std::vector<std::int64_t> lead_index;  // the chunk index along the fixed leading axes
  for (std::size_t k = 0; k + 3 < rank; ++k) {
    lead_offset += (sel.fixed[k] % a.chunks[k]) * stride[k];
    lead_index.push_back(sel.fixed[k] / a.chunks[k]);
  }
  // the chunks that hold the box: [c0, c1) along each axis
  std::array<std::int64_t, 3> first_chunk{}, cn{};
  for (int a3 = 0; a3 < 3; ++a3) {
    first_chunk[a3] = want.lo[a3] / chunk[a3];
    cn[a3] = (want.hi[a3] - 1) / chunk[a3] + 1 - first_chunk[a3];
  }
  (void)grid;
  const std::size_t n_chunks = static_cast<std::size_t>(cn[0] * cn[1] * cn[2]);
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
        if (cancel_requested()) return;  // a frame cancelled while its box is read stops within a chunk
        const auto cc = static_cast<std::int64_t>(c);
        const std::array<std::int64_t, 3> ci{first_chunk[0] + cc % cn[0], first_chunk[1] + cc / cn[0] % cn[1], first_chunk[2] + cc / (cn[0] * cn[1])};
        // the part of the chunk inside the box
        const std::array<std::int64_t, 3> part_lo{std::max(want.lo[0], ci[0] * chunk[0]), std::max(want.lo[1], ci[1] * chunk[1]),
                                                  std::max(want.lo[2], ci[2] * chunk[2])};
        const std::array<std::int64_t, 3> part_hi{std::min(want.hi[0], (ci[0] + 1) * chunk[0]), std::min(want.hi[1], (ci[1] + 1) * chunk[1]),
                                                  std::min(want.hi[2], (ci[2] + 1) * chunk[2])};
        if (held && part_lo[0] >= held->lo[0] && part_lo[1] >= held->lo[1] && part_lo[2] >= held->lo[2] && part_hi[0] <= held->hi[0] &&
            part_hi[1] <= held->hi[1] && part_hi[2] <= held->hi[2]) {  // in memory already: copied (or in place), not read
          const T* src = in_place ? nullptr : held->voxels->data_as<T>();
          const std::int64_t hx = held->hi[0] - held->lo[0], hy = held->hi[1] - held->lo[1];
          for (std::int64_t z = part_lo[2]; src && z < part_hi[2]; ++z)
            for (std::int64_t y = part_lo[1]; y < part_hi[1]; ++y)
              std::memcpy(dst + ((z - want.lo[2]) * want_dims[1] + (y - want.lo[1])) * want_dims[0] + (part_lo[0] - want.lo[0]),
                          src + ((z - held->lo[2]) * hy + (y - held->lo[1])) * hx + (part_lo[0] - held->lo[0]),
                          static_cast<std::size_t>(part_hi[0] - part_lo[0]) * sizeof(T));
          bytes_reused += static_cast<std::uint64_t>((part_hi[0] - part_lo[0]) * (part_hi[1] - part_lo[1]) * (part_hi[2] - part_lo[2])) * sizeof(T);
          continue;
        }
        std::vector<std::int64_t> index = lead_index;
        index.insert(index.end(), {ci[2], ci[1], ci[0]});
        try {
          std::uint64_t read_here = 0;
          std::optional<std::vector<std::byte>> decoded = io_detail::read_zarr_chunk(a, index, chunk_bytes, read_here);
          bytes_read += read_here;
          const bool present = decoded.has_value();
          if (!present) ++missing;
          const std::vector<std::byte> bytes = present ? std::move(*decoded) : std::vector<std::byte>();
          // the part of the chunk inside the box, as rows along x
          const std::int64_t x0 = part_lo[0], x1 = part_hi[0];
          for (std::int64_t z = part_lo[2]; z < part_hi[2]; ++z)
            for (std::int64_t y = part_lo[1]; y < part_hi[1]; ++y) {
              const std::size_t row = static_cast<std::size_t>(((z - want.lo[2]) * want_dims[1] + (y - want.lo[1])) * want_dims[0]);
              const auto at = [&](std::int64_t x) { return row + static_cast<std::size_t>(x - want.lo[0]); };
              if (!present) {
                for (std::int64_t x = x0; x < x1; ++x) store(at(x), a.fill);
                continue;
              }
              const std::int64_t first = lead_offset + (z - ci[2] * chunk[2]) * stride[rank - 3] + (y - ci[1] * chunk[1]) * stride[rank - 2] +
                                         (x0 - ci[0] * chunk[0]) * stride[rank - 1];
              if (direct) {  // the stored type, little-endian, C order: the row's voxels lie side by side
                std::memcpy(dst + at(x0), bytes.data() + first * a.dtype.size,
                            static_cast<std::size_t>(x1 - x0) * sizeof(T));
                continue;
              }
              for (std::int64_t x = x0; x < x1; ++x)
                store(at(x), element(bytes.data() + (first + (x - x0) * stride[rank - 1]) * a.dtype.size, a.dtype));
            }
        } catch (const std::exception& e) {
          const std::lock_guard lock(failure_mutex);
          if (!failure) failure = e.what();
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
  Affine affine = Affine::diagonal(chosen.scale, chosen.translation);
  if (box)  // the box's first voxel is its index 0
    for (int a3 = 0; a3 < 3; ++a3) affine.offset[static_cast<std::size_t>(a3)] += static_cast<double>(want.lo[a3]) * chosen.scale[static_cast<std::size_t>(a3)];
  volume = place_volume(std::move(volume), affine, out);  // a window's origin is still the whole grid's here
  if (level_index > 0) {  // opacities refer to the finest level's voxel, so that every level shows the same matter
    const auto& finest = pyramid.levels.front().scale;
    volume.set_opacity_length(static_cast<float>(std::min({std::abs(finest[0]), std::abs(finest[1]), std::abs(finest[2])})));
  }
  volume.recompute_range();  // rejects NaN voxels (a NaN fill value of missing chunks too) and gives the range
  if (read) {
    read->bytes_read = bytes_read.load();
    read->bytes_reused = bytes_reused.load();
  }
  if (choose && !windowed && chosen_slices.count < whole_dims[2]) {
    if (read) read->whole = true;
    volume = volume.window_z(chosen_slices.first, chosen_slices.count);
    volume.recompute_range();
  } else if (windowed && slices.count < whole_dims[2]) {
    volume.set_window(slices.first, whole_dims[2]);
  }
  return volume;
}

}  // namespace

std::uint64_t default_pyramid_budget() { return physical_memory() / 4; }

Volume load_zarr_volume(const std::string& path, int level, int channel, VolumeFileInfo* info, std::uint64_t memory_budget,
                        const SliceChooser* choose, WindowRead* read) {
  return load_zarr(path, level, channel, info, memory_budget, choose, read, nullptr);
}

Volume load_zarr_box(const std::string& path, int level, int channel, const std::array<std::int64_t, 3>& lo, const std::array<std::int64_t, 3>& hi,
                     WindowRead* read, const HeldBox* held) {
  const IndexBox box{lo, hi};
  return load_zarr(path, level, channel, nullptr, 0, nullptr, read, &box, held);
}

std::vector<LevelGrid> zarr_level_grids(const std::string& path) {
  const fs::path root(path);
  const Pyramid pyramid = read_pyramid(root);
  std::vector<LevelGrid> grids;
  for (const Level& l : pyramid.levels) {
    const ZarrArray a = io_detail::read_zarr_array(root / l.path);
    if (a.shape.size() < 3 || l.scale[0] <= 0 || l.scale[1] <= 0 || l.scale[2] <= 0) return {};
    LevelGrid g;
    for (int a3 = 0; a3 < 3; ++a3) {
      const std::int64_t n = a.shape[a.shape.size() - 1 - static_cast<std::size_t>(a3)];
      if (n < 1 || n > std::numeric_limits<int>::max()) return {};
      g.dims[static_cast<std::size_t>(a3)] = static_cast<int>(n);
      g.spacing[a3] = static_cast<float>(l.scale[static_cast<std::size_t>(a3)]);
      g.origin[a3] = static_cast<float>(l.translation[static_cast<std::size_t>(a3)]);
    }
    g.type = storage_type(a.dtype);
    grids.push_back(g);
  }
  return grids;
}

}  // namespace penumbra
