// The scene file's volumes (a file, a DICOM folder or slice list, a series of files, a procedural
// volume or an array held in memory) and the isosurfaces drawn from them (docs/scene-file.md).
#include "penumbra/scene_io/scene_sections.h"

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <optional>

#include "penumbra/core/byte_size.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/io/volume_reduction.h"
#include "penumbra/data/procedural.h"
#include "penumbra/data/transfer_function_choice.h"

namespace penumbra::scene_sections {
namespace {

RawVolumeOptions read_raw_options(const nlohmann::json& j, const std::string& path) {
  JsonReader r(j, path);
  RawVolumeOptions o;
  const auto& dims = r.raw("dims");
  if (!dims.is_array() || dims.size() != 3) r.fail("dims", "expected [x, y, z], got " + json_brief(dims));
  for (int a = 0; a < 3; ++a) {
    if (!dims[a].is_number_integer()) r.fail("dims", "expected three integers, got " + json_brief(dims));
    o.dims[a] = dims[a].get<std::int64_t>();
  }
  o.type = with_context(r.key_path("type"), [&] { return scalar_type_from_string(r.required_string("type")); });
  const std::string endian = r.string("endian", "little");
  if (endian != "little" && endian != "big") r.fail("endian", "expected \"little\" or \"big\", got \"" + endian + "\"");
  o.big_endian = endian == "big";
  o.spacing = r.vec3("spacing", o.spacing);
  o.header_bytes = static_cast<std::uint64_t>(r.integer("header_bytes", 0, 0, INT64_MAX));
  r.finish();
  return o;
}

// A volume's "file": one path (a volume file or a folder of DICOM slices), or a list of DICOM slices.
std::vector<std::string> volume_file_list(JsonReader& r, const std::string& base_dir) {
  const nlohmann::json& f = r.raw("file");
  if (f.is_string()) return {resolve(base_dir, f.get<std::string>())};
  if (!f.is_array() || f.empty()) r.fail("file", "expected a file name, a folder of DICOM slices, or a list of DICOM slice files");
  std::vector<std::string> paths;
  for (const auto& name : f) {
    if (!name.is_string()) r.fail("file", "lists file names (strings): " + json_brief(name));
    paths.push_back(resolve(base_dir, name.get<std::string>()));
  }
  return paths;
}

// What a volume file needs beyond its name: "raw" (a .raw file's layout), "series" (which DICOM series:
// a SeriesInstanceUID or the index `penumbra info` lists), "channel" (of a multi-channel TIFF or an
// OME-Zarr image or HDF5 dataset), "level" (of an OME-Zarr pyramid: 0 the finest), "dataset" (an HDF5
// file's dataset) and "grid" (of an OpenVDB file: its
// name or index).
VolumeLoadOptions read_volume_load_options(JsonReader& r) {
  VolumeLoadOptions lo;
  if (r.has("raw")) lo.raw = read_raw_options(r.raw("raw"), r.key_path("raw"));
  if (r.has("series")) {
    const nlohmann::json& s = r.raw("series");
    if (s.is_number_integer() && s.get<std::int64_t>() >= 0) lo.series = std::to_string(s.get<std::int64_t>());
    else if (s.is_string() && !s.get<std::string>().empty()) lo.series = s.get<std::string>();
    else r.fail("series", json_brief(s) + " (expected a SeriesInstanceUID or a series index from 0)");
  }
  if (r.has("channel")) lo.channel = static_cast<int>(r.integer("channel", 0, 0, 1 << 20));
  if (r.has("level")) lo.level = static_cast<int>(r.integer("level", 0, 0, 64));
  if (r.has("dataset")) {
    const nlohmann::json& d = r.raw("dataset");
    if (!d.is_string() || d.get<std::string>().empty()) r.fail("dataset", json_brief(d) + " (expected the dataset's path in the HDF5 file, e.g. \"/volume/data\")");
    lo.dataset = d.get<std::string>();
  }
  if (r.has("grid")) {
    const nlohmann::json& g = r.raw("grid");
    if (g.is_number_integer() && g.get<std::int64_t>() >= 0) lo.grid = std::to_string(g.get<std::int64_t>());
    else if (g.is_string() && !g.get<std::string>().empty()) lo.grid = g.get<std::string>();
    else r.fail("grid", json_brief(g) + " (expected an OpenVDB grid name or a grid index from 0)");
  }
  return lo;
}

// The file of step k of a printf-style pattern holding one %d, %Nd or %0Nd (nothing else is a
// conversion: "%%" is a literal percent sign); Error naming `key` for any other pattern.
std::string pattern_file(JsonReader& r, const std::string& pattern, std::size_t k) {
  std::string out;
  int conversions = 0;
  for (std::size_t i = 0; i < pattern.size(); ++i) {
    if (pattern[i] != '%') {
      out += pattern[i];
      continue;
    }
    if (i + 1 < pattern.size() && pattern[i + 1] == '%') {
      out += '%';
      ++i;
      continue;
    }
    std::size_t j = i + 1;
    const bool zeros = j < pattern.size() && pattern[j] == '0';
    std::size_t width = 0;
    while (j < pattern.size() && std::isdigit(static_cast<unsigned char>(pattern[j])) && width < 100)
      width = width * 10 + static_cast<std::size_t>(pattern[j++] - '0');
    if (j >= pattern.size() || pattern[j] != 'd' || width >= 100)
      r.fail("files", "the pattern '" + pattern + "' may hold only %d, %Nd or %0Nd (the step number)");
    std::string number = std::to_string(k);
    if (number.size() < width) number.insert(0, width - number.size(), zeros ? '0' : ' ');
    out += number;
    ++conversions;
    i = j;
  }
  if (conversions != 1) r.fail("files", "the pattern '" + pattern + "' must hold exactly one %d (the step number)");
  return out;
}

// volumes[].files: a list of files (steps in order) or a pattern numbering them from 0 or 1 up to the
// last consecutive one that exists. Resolved against base_dir.
std::vector<std::string> series_files(JsonReader& r, const std::string& base_dir) {
  const nlohmann::json& f = r.raw("files");
  std::vector<std::string> files;
  if (f.is_array()) {
    for (const auto& name : f) {
      if (!name.is_string()) r.fail("files", "lists file names (strings)");
      files.push_back(resolve(base_dir, name.get<std::string>()));
    }
  } else if (f.is_string()) {
    const std::string pattern = resolve(base_dir, f.get<std::string>());
    std::size_t first = std::filesystem::exists(pattern_file(r, pattern, 0)) ? 0 : 1;
    for (std::size_t k = first; std::filesystem::exists(pattern_file(r, pattern, k)); ++k) files.push_back(pattern_file(r, pattern, k));
    if (files.empty())
      r.fail("files", "no file matches '" + pattern + "' (tried " + pattern_file(r, pattern, 0) + " and " +
                          pattern_file(r, pattern, 1) + ")");
  } else {
    r.fail("files", "expected a list of file names or a pattern such as \"run_%04d.nrrd\"");
  }
  if (files.empty()) r.fail("files", "is an empty list");
  return files;
}

// Every step of a series must share the grid of the first one loaded (Error naming the file).
void check_same_grid(JsonReader& r, const SeriesGrid& first, const Volume& step, const std::string& file) {
  auto grid = [](const std::array<int, 3>& d, ScalarType type, const Vec3& spacing) {
    return std::to_string(d[0]) + "×" + std::to_string(d[1]) + "×" + std::to_string(d[2]) + " " + to_string(type) +
           " voxels of " + std::to_string(spacing.x) + " " + std::to_string(spacing.y) + " " + std::to_string(spacing.z);
  };
  if (first.dims != step.dims() || first.type != step.type() || !(first.spacing == step.spacing()) || !(first.origin == step.origin()))
    r.fail("files", "'" + file + "' holds " + grid(step.dims(), step.type(), step.spacing()) + ", but '" + first.file +
                        "' holds " + grid(first.dims, first.type, first.spacing) +
                        " (every step must have the same grid, voxel type, spacing and origin)");
}

// What `volume` holds against the scene's memory_budget (voxels and macrocells; an array viewed in
// place costs its macrocells only: its voxels are the caller's); Error naming `source` (and, for a
// `file`, how to make a pyramid of it) when that is over `left`.
std::uint64_t budgeted_bytes(const Volume& volume, const std::string& source, bool file, std::uint64_t left) {
  const std::uint64_t voxels = volume.stored_voxel_count();
  const auto& d = volume.dims();
  const std::uint64_t held = macrocell_held_bytes({d[0], d[1], d[2]}) + (volume.is_view() ? 0 : voxels * scalar_size(volume.type()));
  if (held > left)
    throw Error(source + " holds " + byte_size_string(held) + " (" + std::to_string(voxels) + " voxels of " + to_string(volume.type()) +
                " and their macrocells), over the " + byte_size_string(left) + " left of memory_budget; " +
                (file ? "write it as an OME-Zarr pyramid (`penumbra convert " + source + " -o " +
                            std::filesystem::path(source).stem().string() + ".zarr`) and open a level that fits"
                      : std::string("raise memory_budget")));
  return held;
}

// The levels `opened` is one of: those of the OME-Zarr pyramid at `path` when `opened` is one of them but
// not the finest (recognised by its grid), or the file's reductions when it was read reduced under the
// budget (volume_reduction.h); nullptr otherwise. `origin` (the scene's) moves the finest level's first
// voxel there and every level with it, so that a coarser level and its finer boxes lie where the data at
// full resolution would.
std::shared_ptr<const PyramidSource> refinement_levels(const std::string& path, const VolumeLoadOptions& options, const Volume& opened,
                                                       const std::string& key, const std::optional<Vec3>& origin) {
  const bool store = is_zarr_store(path);
  // a file read at full resolution has no coarser level (its opacities refer to its own voxel; a reduced
  // one's to the file's smaller one): its header is not read again
  const Vec3& s = opened.spacing();
  if (!store && opened.opacity_length() >= std::min({s.x, s.y, s.z})) return nullptr;
  const std::vector<LevelGrid> grids = store ? zarr_level_grids(path) : reduced_level_grids(path, options, opened);
  auto source = std::make_shared<PyramidSource>();
  source->path = path;
  source->key = key;
  source->opened = -1;
  for (std::size_t l = 0; l < grids.size(); ++l) {
    const LevelGrid& g = grids[l];
    source->levels.push_back({g.dims, g.spacing, g.origin});
    if (g.dims == opened.dims() && length(g.spacing - opened.spacing()) <= 1e-4f * length(g.spacing)) source->opened = static_cast<int>(l);
  }
  if (source->opened <= 0) return nullptr;
  source->type = grids.front().type;
  const Vec3 shift = origin ? *origin - source->levels.front().origin : Vec3{0, 0, 0};
  for (PyramidSource::Level& l : source->levels) l.origin += shift;
  // a file's grid as its header gives it, read once here rather than for every box
  source->read_box = [path, options, store, shift, file_level = grids.front()](int level, const std::array<std::int64_t, 3>& lo,
                                                                               const std::array<std::int64_t, 3>& hi, WindowRead* read,
                                                                               const HeldBox* held) {
    Volume box = store ? load_zarr_box(path, level, options.channel, lo, hi, read, held)
                       : load_reduced_box(path, options, file_level, level, lo, hi, read, held);
    box.set_origin(box.origin() + shift);
    return box;
  };
  return source;
}

}  // namespace

VolumeObject read_volume(const nlohmann::json& j, const std::string& path, const std::string& base_dir, const SceneReadOptions& options,
                         std::size_t time, std::uint64_t* budget_left) {
  JsonReader r(j, path);
  VolumeObject v;
  require_one_source(r);
  std::optional<Vec3> origin;
  if (r.has("origin")) origin = r.vec3("origin", {});
  if (r.has("spacing") && !r.has("array"))
    r.fail("spacing", "is given with 'array' only (a file's spacing is in its header, or in 'raw')");
  std::function<Volume()> load;
  const bool refine = r.boolean("refine", true);
  // a store or a file that may open coarser than its data, read so: its levels (VolumeObject::pyramid)
  std::optional<VolumeLoadOptions> leveled;
  bool refinable = false;  // full frames may refine it
  std::string data_id = data_key(j, base_dir, {"file", "files", "raw", "series", "channel", "level", "dataset", "grid", "procedural", "array", "spacing", "origin"});
  std::string series_id;  // a series: what its first loaded step is cached under (the reference grid and range)
  if (r.has("file") || r.has("files")) {
    std::string file;
    if (r.has("files")) {
      const std::vector<std::string> files = series_files(r, base_dir);
      if (time >= files.size())
        throw Error("time: frame " + std::to_string(time) + " is past the last step of " + r.key_path("files") + " (" +
                    std::to_string(files.size()) + " steps, 0 to " + std::to_string(files.size() - 1) + ")");
      file = files[time];
      v.frames = files.size();
      series_id = data_id + "@series";
      data_id += "@" + file;
    }
    // one file (or folder of DICOM slices), or a list of DICOM slices that make one volume
    std::vector<std::string> paths = file.empty() ? volume_file_list(r, base_dir) : std::vector<std::string>{file};
    VolumeLoadOptions lo = read_volume_load_options(r);
    lo.confine_to = options.confine_to;
    if (budget_left) {  // a pyramid's level depends on what is left
      lo.memory_budget = *budget_left;
      data_id += "@budget=" + std::to_string(*budget_left);
    }
    const std::string key = r.has("files") ? "files" : "file";
    const auto* reader = options.volume_reader;
    // a pyramid, or a file that may be read reduced under the budget (one step of a series too), read
    // whole (not a rank's window): its levels place it; where memory chose the level (not 'level'),
    // finer levels refine full frames
    if (!reader && paths.size() == 1 && (is_zarr_store(paths[0]) || (budget_left && reads_slices_in_part(paths, lo)))) {
      leveled = lo;
      refinable = refine && lo.level < 0;
    }
    load = [&r, paths, lo, key, reader] {
      return with_context(r.key_path(key), [&] { return reader ? (*reader)(paths, lo) : load_volume(paths, lo); });
    };
    v.source = paths.size() == 1 ? paths[0] : paths[0] + " (+" + std::to_string(paths.size() - 1) + " slices)";
  } else if (r.has("procedural")) {
    nlohmann::json spec = r.raw("procedural");
    if (spec.is_object() && spec.contains("frames")) {  // a generated time series: step `time` of it
      const nlohmann::json& n = spec["frames"];
      if (!n.is_number_integer() || n.get<std::int64_t>() < 1 || n.get<std::int64_t>() > 1000000)
        r.fail("procedural", "\"frames\": " + n.dump() + " (expected an integer in 1..1000000)");
      v.frames = static_cast<std::size_t>(n.get<std::int64_t>());
      if (time >= v.frames)
        throw Error("time: frame " + std::to_string(time) + " is past the last step of " + r.key_path("procedural") + " (" +
                    std::to_string(v.frames) + " frames)");
      spec["frame"] = time;
      series_id = data_id + "@series";
      data_id += "@frame=" + std::to_string(time);
    }
    load = [&r, spec, &base_dir] { return with_context(r.key_path("procedural"), [&] { return make_procedural_volume(spec, base_dir); }); };
    v.source = "procedural:" + (spec.contains("name") && spec["name"].is_string() ? spec["name"].get<std::string>() : "?");
  } else {
    const std::shared_ptr<const Volume> array = named_array(r, options.arrays, &SceneArrays::volumes, "volume");
    std::optional<Vec3> spacing;
    if (r.has("spacing")) spacing = r.vec3("spacing", {});
    load = [&r, array, spacing] {  // a copy of a view shares the voxels
      Volume placed = *array;
      if (spacing) with_context(r.key_path("spacing"), [&] { placed.set_spacing(*spacing); });
      return placed;
    };
    data_id += "@" + std::to_string(reinterpret_cast<std::uintptr_t>(array.get()));  // replaced data is new data
    v.source = "array:" + r.required_string("array");
  }
  // the levels, found once per data (a file read reduced reads its header for them)
  std::optional<std::shared_ptr<const PyramidSource>> levels;
  const std::string source_key = r.has("file") ? "file" : r.has("files") ? "files" : r.has("procedural") ? "procedural" : "array";
  auto find_levels = [&](const Volume& opened) {
    if (!levels) levels = with_context(r.key_path(source_key), [&] { return refinement_levels(v.source, *leveled, opened, data_id, origin); });
    return *levels;
  };
  auto load_placed = [&] {
    Volume vol = load();
    if (origin) {  // a level coarser than the data moves with the data's first voxel
      const std::shared_ptr<const PyramidSource> pyramid = leveled ? find_levels(vol) : nullptr;
      vol.set_origin(pyramid ? pyramid->levels[static_cast<std::size_t>(pyramid->opened)].origin : *origin);
    }
    return vol;
  };
  const std::shared_ptr<Volume> volume = options.cache ? options.cache->volume(data_id, load_placed) : std::make_shared<Volume>(load_placed());
  if (budget_left) *budget_left -= with_context(r.key_path(source_key), [&] { return budgeted_bytes(*volume, v.source, source_key == "file" || source_key == "files", *budget_left); });
  // A series keeps the grid and value range of the first step it loaded: every step must share that
  // grid, and the transfer function reads that range, so colours hold still while the data change.
  float range_lo = volume->min_value(), range_hi = volume->max_value();
  if (!series_id.empty() && options.cache) {
    const SeriesGrid& first = options.cache->series(series_id, *volume, v.source);
    check_same_grid(r, first, *volume, v.source);
    range_lo = first.min_value;
    range_hi = first.max_value;
  }
  const std::string tf_id = series_id.empty() ? data_id : series_id;
  v.visible = r.boolean("visible", true);
  // A hidden volume (one only isosurfaces are drawn from) needs no transfer function.
  if (r.has("transfer_function"))
    v.transfer_function = with_context(r.key_path("transfer_function"), [&] {
      return parse_transfer_function(r.raw("transfer_function"), range_lo, range_hi, base_dir);
    });
  else if (v.visible)  // one chosen from the data
    v.transfer_function = parse_transfer_function(
        options.cache ? options.cache->chosen_transfer_function(tf_id, *volume) : choose_transfer_function(*volume),
        range_lo, range_hi, base_dir);
  if (r.has("shadow_transfer_function")) {
    v.has_shadow_transfer_function = true;
    v.shadow_transfer_function = with_context(r.key_path("shadow_transfer_function"), [&] {
      return parse_transfer_function(r.raw("shadow_transfer_function"), range_lo, range_hi, base_dir);
    });
  }
  v.step = r.number("step", v.step, 0.05f, 8.0f);
  const std::string comp = r.string("compositing", "alpha");
  if (comp == "alpha") v.compositing = Compositing::Alpha;
  else if (comp == "extinction") v.compositing = Compositing::Extinction;
  else r.fail("compositing", "unknown value '" + comp + "' (expected alpha or extinction)");
  v.jitter = r.boolean("jitter", true);
  const std::string gradients = r.string("gradients", "auto");
  if (gradients == "auto") v.gradients = VolumeObject::Gradients::Auto;
  else if (gradients == "stored") v.gradients = VolumeObject::Gradients::Stored;
  else if (gradients == "on_the_fly") v.gradients = VolumeObject::Gradients::OnTheFly;
  else r.fail("gradients", "unknown value '" + gradients + "' (expected auto, stored or on_the_fly)");
  if (budget_left && v.visible) {  // stored gradients take from the budget; auto stores them only where they fit
    const std::uint64_t gradient_bytes = volume->stored_voxel_count() * kGradientBytesPerVoxel;
    const bool fit = gradient_bytes <= *budget_left;
    if (v.gradients == VolumeObject::Gradients::Stored && !fit)
      r.fail("gradients", "\"stored\" needs " + byte_size_string(gradient_bytes) + ", over the " + byte_size_string(*budget_left) +
                              " left of memory_budget (\"auto\" computes them per sample instead)");
    if (v.gradients == VolumeObject::Gradients::Auto)
      v.gradients = fit && gradient_bytes <= kStoredGradientBytes ? VolumeObject::Gradients::Stored : VolumeObject::Gradients::OnTheFly;
    if (v.gradients == VolumeObject::Gradients::Stored) *budget_left -= gradient_bytes;
  }
  if (!v.visible)
    for (const char* key : {"casts_shadows", "receives_shadows"})
      if (r.has(key)) r.fail(key, "the volume is not visible ('visible': false): it neither casts nor receives shadows");
  read_shadow_flags(r, v);
  r.finish();
  if (refinable)  // a hidden volume's isosurfaces refine too
    v.pyramid = options.cache ? options.cache->pyramid(data_id, [&] { return find_levels(*volume); }) : find_levels(*volume);
  v.volume = std::move(volume);
  return v;
}

IsosurfaceObject read_isosurface(const nlohmann::json& j, const std::string& path, const std::vector<VolumeObject>& volumes) {
  JsonReader r(j, path);
  IsosurfaceObject o;
  if (volumes.empty()) r.fail("volume", "the scene has no volumes (an isosurface is drawn from one of 'volumes')");
  o.volume = static_cast<std::size_t>(r.integer("volume", 0, 0, INT32_MAX));
  if (o.volume >= volumes.size())
    r.fail("volume", "index " + std::to_string(o.volume) + " but the scene has " + std::to_string(volumes.size()) + " volume(s)");
  const VolumeObject& v = volumes[o.volume];
  const float lo = v.volume->min_value(), hi = v.volume->max_value();
  if (!(lo < hi)) r.fail("volume", v.source + " is constant (every voxel is " + num(lo) + "): it has no isosurface");
  if (!r.has("value")) r.fail("value", "missing: the isovalue, in the data units of " + v.source);
  o.value = r.number("value", 0, -3.0e38f, 3.0e38f);
  if (!(o.value > lo && o.value <= hi))
    r.fail("value", num(o.value) + " is outside the data range (" + num(lo) + ", " + num(hi) + "] of " + v.source +
                        ": the isosurface would be empty");
  o.method = with_context(r.key_path("method"), [&] { return isosurface_method_from_string(r.string("method", "points")); });
  o.color = r.color("color", o.color);
  o.collapse = r.boolean("collapse", o.collapse);
  read_shadow_flags(r, o);
  r.finish();
  return o;
}

}  // namespace penumbra::scene_sections
