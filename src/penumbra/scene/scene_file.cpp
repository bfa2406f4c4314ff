#include "penumbra/scene/scene_file.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include "penumbra/accel/extinction_sat.h"
#include "penumbra/data/io/particle_io.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/procedural.h"
#include "penumbra/data/transfer_function_choice.h"
#include "penumbra/scene/json_reader.h"
#include "penumbra/scene/technique_catalog.h"

namespace penumbra {
namespace {

std::string join(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

std::string resolve(const std::string& base_dir, const std::string& file) {
  const std::filesystem::path p(file);
  return p.is_absolute() || base_dir.empty() ? file : (std::filesystem::path(base_dir) / p).string();
}

Camera read_camera(const nlohmann::json& j, const Box3& bounds) {
  JsonReader r(j, "camera");
  Camera c;
  c.fov_deg = r.number("fov_deg", c.fov_deg, 1, 170);
  c.width = static_cast<int>(r.integer("width", c.width, 1, 16384));
  c.height = static_cast<int>(r.integer("height", c.height, 1, 16384));
  c.up = r.vec3("up", c.up);
  if (length(c.up) == 0) r.fail("up", "must not be the zero vector");
  // Without an eye, frame the scene: look at the bounds' centre from `direction`, far enough back that
  // the bounding sphere fills the view, as ParaView's "reset camera" does.
  const Vec3 centre = bounds.empty() ? Vec3{0, 0, 0} : bounds.center();
  c.target = r.vec3("target", centre);
  const Vec3 dir = normalize(r.vec3("direction", {1.0f, 0.55f, 1.3f}));
  if (length(dir) == 0) r.fail("direction", "must not be the zero vector");
  const float radius = bounds.empty() ? 1.0f : bounds.radius();
  // zoom > 1 moves the framed camera closer (the bounds' sphere is loose for elongated data)
  const float zoom = r.number("zoom", 1, 0.01f, 100);
  const float dist = r.number("distance", radius / std::sin(radians(c.fov_deg) * 0.5f) * 1.05f / zoom, 1e-6f);
  c.eye = r.vec3("eye", c.target + dir * dist);
  if (length(c.eye - c.target) == 0) r.fail("eye", "must differ from target");
  r.finish();
  return c;
}

Light read_light(const nlohmann::json& j, const std::string& path, const Box3& bounds) {
  JsonReader r(j, path);
  Light l;
  const std::string type = r.string("type", "directional");
  if (type == "directional") l.type = LightType::Directional;
  else if (type == "point") l.type = LightType::Point;
  else if (type == "spot") l.type = LightType::Spot;
  else r.fail("type", "unknown light type '" + type + "' (expected directional, point or spot)");
  l.color = r.color("color", l.color);
  l.intensity = r.number("intensity", l.intensity, 0, 1e6f);
  const Vec3 centre = bounds.empty() ? Vec3{0, 0, 0} : bounds.center();
  if (l.type == LightType::Directional) {
    l.direction = normalize(r.vec3("direction", {-0.4f, -1.0f, -0.3f}));
    if (length(l.direction) == 0) r.fail("direction", "must not be the zero vector");
  } else {
    if (!r.has("position")) r.fail("position", "missing (a " + type + " light needs a position)");
    l.position = r.vec3("position", {});
    if (l.type == LightType::Spot) {
      l.direction = normalize(r.vec3("direction", centre - l.position));
      if (length(l.direction) == 0) r.fail("direction", "must not be the zero vector");
      l.angle_deg = r.number("angle_deg", l.angle_deg, 0.1f, 89.0f);
      l.softness = r.number("softness", l.softness, 0, 1);
    }
  }
  r.finish();
  return l;
}

// casts_shadows / receives_shadows (default true) of any object that is drawn.
void read_shadow_flags(JsonReader& r, ShadowFlags& f) {
  f.casts_shadows = r.boolean("casts_shadows", f.casts_shadows);
  f.receives_shadows = r.boolean("receives_shadows", f.receives_shadows);
}

Plane read_plane(const nlohmann::json& j, const std::string& path) {
  JsonReader r(j, path);
  Plane p;
  p.point = r.vec3("point", p.point);
  p.normal = normalize(r.vec3("normal", p.normal));
  if (length(p.normal) == 0) r.fail("normal", "must not be the zero vector");
  p.color = r.color("color", p.color);
  p.size = r.number("size", p.size, 0);
  read_shadow_flags(r, p);
  r.finish();
  return p;
}

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

// What defines an object's data (the keys `keys` of it, with the folder relative files resolve against).
std::string data_key(const nlohmann::json& j, const std::string& base_dir, std::initializer_list<const char*> keys, bool all_but = false) {
  nlohmann::json k = nlohmann::json::object();
  k["base_dir"] = base_dir;
  for (const auto& item : j.items()) {
    const std::string& key = item.key();
    const bool listed = std::find_if(keys.begin(), keys.end(), [&](const char* n) { return key == n; }) != keys.end();
    if (listed != all_but) k[key] = item.value();
  }
  return k.dump();
}

// The in-memory data that `"array"` names, or an Error naming the key.
template <class Data>
std::shared_ptr<const Data> named_array(JsonReader& r, const SceneArrays* arrays, const std::map<std::string, std::shared_ptr<const Data>> SceneArrays::*kind,
                                        const char* what) {
  const std::string name = r.required_string("array");
  if (!arrays)
    r.fail("array", "names data held in memory by the Python package's builders; a scene file gives 'file' or 'procedural'");
  const auto& known = arrays->*kind;
  const auto it = known.find(name);
  if (it == known.end()) {
    std::string names;
    for (const auto& k : known) names += (names.empty() ? "" : ", ") + k.first;
    r.fail("array", "no " + std::string(what) + " array named \"" + name + "\" (known: " + (names.empty() ? "none" : names) + ")");
  }
  return it->second;
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
// a SeriesInstanceUID or the index `penumbra info` lists), "channel" (of a multi-channel TIFF) and
// "grid" (of an OpenVDB file: its name or index).
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
  if (r.has("grid")) {
    const nlohmann::json& g = r.raw("grid");
    if (g.is_number_integer() && g.get<std::int64_t>() >= 0) lo.grid = std::to_string(g.get<std::int64_t>());
    else if (g.is_string() && !g.get<std::string>().empty()) lo.grid = g.get<std::string>();
    else r.fail("grid", json_brief(g) + " (expected an OpenVDB grid name or a grid index from 0)");
  }
  return lo;
}

// Exactly one of the keys that say where an object's data comes from (volumes may give "files").
void require_one_source(JsonReader& r) {
  const int sources = int(r.has("file")) + int(r.has("procedural")) + int(r.has("array")) + int(r.has("files"));
  if (sources != 1)
    r.fail(r.has("file") ? "file" : r.has("procedural") ? "procedural" : r.has("array") ? "array" : "files",
           sources == 0 ? "missing: give 'file' or 'procedural'"
                        : "give exactly one of 'file', 'files', 'procedural' and 'array'");
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

VolumeObject read_volume(const nlohmann::json& j, const std::string& path, const std::string& base_dir, const SceneReadOptions& options,
                         std::size_t time) {
  JsonReader r(j, path);
  VolumeObject v;
  require_one_source(r);
  std::optional<Vec3> origin;
  if (r.has("origin")) origin = r.vec3("origin", {});
  if (r.has("spacing") && !r.has("array"))
    r.fail("spacing", "is given with 'array' only (a file's spacing is in its header, or in 'raw')");
  std::function<Volume()> load;
  std::string data_id = data_key(j, base_dir, {"file", "files", "raw", "series", "channel", "grid", "procedural", "array", "spacing", "origin"});
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
    const std::string key = r.has("files") ? "files" : "file";
    const auto* reader = options.volume_reader;
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
  auto load_placed = [&] {
    Volume vol = load();
    if (origin) vol.set_origin(*origin);
    return vol;
  };
  const std::shared_ptr<Volume> volume = options.cache ? options.cache->volume(data_id, load_placed) : std::make_shared<Volume>(load_placed());
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
  if (!v.visible)
    for (const char* key : {"casts_shadows", "receives_shadows"})
      if (r.has(key)) r.fail(key, "the volume is not visible ('visible': false): it neither casts nor receives shadows");
  read_shadow_flags(r, v);
  r.finish();
  v.volume = std::move(volume);
  return v;
}

ParticleObject read_static_particles(const nlohmann::json& j, const std::string& path, const std::string& base_dir, const SceneReadOptions& options) {
  if (j.is_object() && j.contains("array")) {  // the caller's spheres, as they are
    JsonReader r(j, path);
    ParticleObject p;
    require_one_source(r);
    p.set = named_array(r, options.arrays, &SceneArrays::particles, "particle");
    p.source = "array:" + r.required_string("array");
    read_shadow_flags(r, p);
    r.finish();
    return p;
  }
  if (options.cache && j.is_object()) {  // everything but the shadow flags defines the spheres and their colours
    JsonReader r(j, path);
    ParticleObject p;
    p.set = options.cache->particles(data_key(j, base_dir, {"casts_shadows", "receives_shadows"}, true), [&] {
      return ParticleSet(*read_static_particles(j, path, base_dir, SceneReadOptions{}).set);
    });
    p.source = r.has("file") ? resolve(base_dir, r.required_string("file")) : "procedural:random-spheres";
    read_shadow_flags(r, p);
    return p;
  }
  JsonReader r(j, path);
  ParticleObject p;
  require_one_source(r);
  const bool has_file = r.has("file");
  if (has_file) {
    const std::string file = resolve(base_dir, r.required_string("file"));
    ParticleLoadOptions o;
    o.assembly = static_cast<int>(r.integer("assembly", 0, 0, 1000000));
    const std::string color_by = r.string("color_by", "element");
    o.coloring = with_context(r.key_path("color_by"), [&] { return particle_coloring_from_string(color_by); });
    o.uniform_color = r.color("color", o.uniform_color);
    if (r.has("color") && o.coloring != ParticleColoring::Uniform)
      r.fail("color", "is used only with \"color_by\": \"uniform\"");
    if (o.coloring == ParticleColoring::Scalar) {
      o.scalar = with_context(r.key_path("scalar"), [&] { return particle_scalar_from_string(r.string("scalar", "b_factor")); });
      if (r.has("color_map")) {
        const nlohmann::json spec = r.raw("color_map");
        const std::string where = r.key_path("color_map");
        o.color_map = [spec, where, base_dir](float lo, float hi) {
          return with_context(where, [&] { return parse_transfer_function(spec, lo, hi, base_dir); });
        };
      }
    } else {
      for (const char* key : {"scalar", "color_map"})
        if (r.has(key)) r.fail(key, "is used only with \"color_by\": \"scalar\"");
    }
    if (r.has("radius") && r.has("radius_scale"))
      r.fail("radius", "give 'radius' (one radius for every sphere) or 'radius_scale' (scales the element radii), not both");
    o.radius_scale = r.number("radius_scale", o.radius_scale, 0.01f, 100);
    o.hydrogens = r.boolean("hydrogens", o.hydrogens);
    ParticleSet set = with_context(r.key_path("file"), [&] { return load_particles(file, o); });
    // One radius for every sphere (beads, SPH particles, coarse-grained models have no element radii).
    if (r.has("radius")) {
      const float radius = r.number("radius", 1, 1e-6f, 1e6f);
      for (Sphere& sp : set.spheres) sp.radius = radius;
    }
    p.set = std::make_shared<ParticleSet>(std::move(set));
    p.source = file;
  } else {
    if (r.has("radius")) r.fail("radius", "generated spheres take their radius inside 'procedural'");
    JsonReader g(r.raw("procedural"), r.key_path("procedural"));
    const std::string name = g.required_string("name");
    if (name != "random-spheres") g.fail("name", "unknown particle generator '" + name + "' (expected random-spheres)");
    const auto count = static_cast<std::size_t>(g.integer("count", 1000, 1, 100000000));
    const float radius = g.number("radius", 0.02f, 1e-6f, 1);
    const auto seed = static_cast<std::uint64_t>(g.integer("seed", 1, 0, INT64_MAX));
    g.finish();
    p.set = std::make_shared<ParticleSet>(random_spheres(count, radius, seed));
    p.source = "procedural:random-spheres";
  }
  if (r.has("origin")) {  // moves the set so that its bounding box's centre is here
    const Vec3 o = r.vec3("origin", {});
    auto moved = std::make_shared<ParticleSet>(*p.set);
    const Vec3 shift = o - p.set->bounds().center();
    for (auto& sp : moved->spheres) sp.center = sp.center + shift;
    p.set = std::move(moved);
  }
  if (p.set->size() == 0) r.fail(has_file ? "file" : "procedural", "holds no particles");
  read_shadow_flags(r, p);
  r.finish();
  return p;
}

// The files of particles[].trajectory: one file or a list (frames in the order given), resolved.
std::vector<std::string> trajectory_files(JsonReader& r, const std::string& base_dir) {
  const nlohmann::json& t = r.raw("trajectory");
  std::vector<std::string> files;
  if (t.is_string()) files.push_back(resolve(base_dir, t.get<std::string>()));
  if (t.is_array())
    for (const auto& f : t) {
      if (!f.is_string()) r.fail("trajectory", "lists file names (strings)");
      files.push_back(resolve(base_dir, f.get<std::string>()));
    }
  if (files.empty()) r.fail("trajectory", "expected a file name or a non-empty list of file names");
  return files;
}

// particles[] with a "trajectory": the topology (its `file`, read as a static set: radii, colours) with
// every sphere moved to its atom's position at frame `time` (sphere i is atom i, so the topology keeps
// every atom: no assembly, hydrogens kept). The trajectory stays open in the cache between frames.
ParticleObject read_trajectory_particles(const nlohmann::json& j, const std::string& path, const std::string& base_dir,
                                         const SceneReadOptions& options, std::size_t time) {
  JsonReader r(j, path);
  if (!r.has("file")) r.fail("trajectory", "needs a topology: give the particles' 'file' (PDB, mmCIF, GRO or XYZ) beside it");
  if (r.integer("assembly", 0, 0, 1000000) != 0)
    r.fail("assembly", "cannot be used with a trajectory: its frames hold the deposited atoms, not an assembly");
  if (!r.boolean("hydrogens", true))
    r.fail("hydrogens", "cannot be false with a trajectory: its frames hold every atom of the topology");
  const std::vector<std::string> files = trajectory_files(r, base_dir);
  nlohmann::json topology_json = j;
  topology_json.erase("trajectory");
  topology_json.erase("origin");  // the shift is applied to every frame below
  ParticleObject p = read_static_particles(topology_json, path, base_dir, options);
  const std::shared_ptr<const ParticleSet> topology_set = p.set;  // p.set becomes the frame below
  const ParticleSet& topology = *topology_set;
  auto open = [&] {
    return with_context(r.key_path("trajectory"), [&] { return open_trajectory(files, topology.size()); });
  };
  std::unique_ptr<TrajectoryReader> own;
  TrajectoryReader& reader = options.cache ? options.cache->trajectory(nlohmann::json(files).dump(), open) : *(own = open());
  if (reader.atom_count() != topology.size())
    r.fail("trajectory", "holds " + std::to_string(reader.atom_count()) + " atoms a frame, but the topology '" +
                             p.source + "' has " + std::to_string(topology.size()));
  if (time >= reader.frame_count())
    throw Error("time: frame " + std::to_string(time) + " is past the last frame of " + r.key_path("trajectory") + " (" +
                std::to_string(reader.frame_count()) + " frames, 0 to " + std::to_string(reader.frame_count() - 1) + ")");
  const Vec3 shift = r.has("origin") ? r.vec3("origin", {}) - topology.bounds().center() : Vec3{};
  double time_ps = 0;
  auto load_frame = [&] {
    TrajectoryFrame frame;
    with_context(r.key_path("trajectory"), [&] { reader.read_frame(time, frame); });
    ParticleSet moved = topology;
    for (std::size_t i = 0; i < moved.spheres.size(); ++i) moved.spheres[i].center = frame.positions[i] + shift;
    time_ps = frame.time_ps;
    return moved;
  };
  // a frame read once per time: edits of anything else keep the same spheres
  if (options.cache) {
    std::string key = data_key(j, base_dir, {"casts_shadows", "receives_shadows"}, true) + "@time=" + std::to_string(time);
    bool loaded = false;
    p.set = options.cache->particles(key, [&] {
      loaded = true;
      return load_frame();
    });
    double& stored = options.cache->frame_time_ps(key);
    if (loaded) stored = time_ps;
    p.time_ps = stored;
  } else {
    p.set = std::make_shared<const ParticleSet>(load_frame());
    p.time_ps = time_ps;
  }
  p.topology_bounds = topology.bounds();
  if (r.has("origin")) {
    p.topology_bounds.lo = p.topology_bounds.lo + shift;
    p.topology_bounds.hi = p.topology_bounds.hi + shift;
  }
  p.frames = reader.frame_count();
  return p;
}

ParticleObject read_particles(const nlohmann::json& j, const std::string& path, const std::string& base_dir,
                              const SceneReadOptions& options, std::size_t time) {
  if (j.is_object() && j.contains("trajectory")) return read_trajectory_particles(j, path, base_dir, options, time);
  return read_static_particles(j, path, base_dir, options);
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

void check_technique(JsonReader& r, const std::string& name, const std::vector<std::string>& available) {
  if (std::find(available.begin(), available.end(), name) != available.end()) return;
  r.fail("technique", "unknown technique '" + name + "' (expected one of: " + join(available) + ")");
}

ShadowSettings read_shadows(const nlohmann::json& j) {
  JsonReader r(j, "shadows");
  ShadowSettings s;
  s.technique = r.string("technique", s.technique);
  check_technique(r, s.technique, technique_names(TechniqueFamily::Shadow));
  s.resolution = static_cast<int>(r.integer("resolution", s.resolution, 16, 16384));
  s.offsets = static_cast<int>(r.integer("offsets", s.offsets, 1, 21));
  if (s.offsets != 7 && s.offsets != 13 && s.offsets != 21)
    r.fail("offsets", "value " + std::to_string(s.offsets) + " is not supported (expected 7, 13 or 21, paper §4)");
  s.seed = static_cast<std::uint64_t>(r.integer("seed", static_cast<std::int64_t>(s.seed), 0, INT64_MAX));
  s.nodes = static_cast<int>(r.integer("nodes", s.nodes, 2, 64));
  s.dsm_layout = r.string("dsm_layout", s.dsm_layout);
  if (s.dsm_layout != "per_channel" && s.dsm_layout != "shared_depth")
    r.fail("dsm_layout", "unknown value '" + s.dsm_layout + "' (expected per_channel or shared_depth)");
  s.pcf = static_cast<int>(r.integer("pcf", s.pcf, 0, 16));
  s.bias = r.number("bias", s.bias, -1, 1e6f);
  if (s.bias < 0 && s.bias != -1) r.fail("bias", "must be at least 0 (or -1 for the automatic bias)");
  s.step = r.number("step", s.step, -1, 8);
  if (s.step < 0.05f && s.step != -1) r.fail("step", "must be at least 0.05 voxels (or -1 for the default, one voxel)");
  s.cone_angle = r.number("cone_angle", s.cone_angle, 0, 90);
  if (s.cone_angle >= 90) r.fail("cone_angle", "must be below 90 degrees (the cone's half-angle)");
  s.cone_samples = r.number("cone_samples", s.cone_samples, 1, 4096);
  s.cone_growth = r.number("cone_growth", s.cone_growth, 0, 1);
  s.cone_rays = static_cast<int>(r.integer("cone_rays", s.cone_rays, 1, 4096));
  s.rings = static_cast<int>(r.integer("rings", s.rings, -1, 64));
  s.soft_radius = r.number("soft_radius", s.soft_radius, 0, 1e6f);
  s.soft_exponent = r.number("soft_exponent", s.soft_exponent, 0.01f, 100);
  s.soft_distance = r.number("soft_distance", s.soft_distance, 1e-6f, 1e6f);
  s.light_angle = r.number("light_angle", s.light_angle, 0, 45);
  s.area_rays = static_cast<int>(r.integer("area_rays", s.area_rays, 1, 65536));
  s.light_frustum = r.string("light_frustum", s.light_frustum);
  if (s.light_frustum != "tight" && s.light_frustum != "volume")
    r.fail("light_frustum", "unknown value '" + s.light_frustum + "' (expected tight or volume)");
  for (int i = 0; i < kObjectKinds; ++i) {  // shadows.volumes, .spheres, .isosurfaces, .planes
    const auto kind = static_cast<ObjectKind>(i);
    const std::string key = to_string(kind);
    if (!r.has(key)) continue;
    const std::string name = r.string(key, "");
    const std::vector<std::string> takes = technique_names(TechniqueFamily::Shadow, kind);
    if (std::find(takes.begin(), takes.end(), name) == takes.end())
      r.fail(key, "technique '" + name + "' does not take " + key + " as casters (expected one of: " + join(takes) + ")");
    s.by_kind[static_cast<std::size_t>(i)] = name;
  }
  r.finish();
  return s;
}

AmbientSettings read_ambient(const nlohmann::json& j) {
  JsonReader r(j, "ambient");
  AmbientSettings a;
  a.technique = r.string("technique", a.technique);
  check_technique(r, a.technique, technique_names(TechniqueFamily::Ambient));
  a.shells = static_cast<int>(r.integer("shells", a.shells, 1, 64));
  a.radius = r.number("radius", a.radius, 0, 1);
  if (!(a.radius > 0)) r.fail("radius", "must be positive (a fraction of the volume's longest side, e.g. 0.05)");
  a.bleeding = r.number("bleeding", a.bleeding, 0, 1);
  a.directions = static_cast<int>(r.integer("directions", a.directions, 1, 1024));
  a.max_distance = r.number("max_distance", a.max_distance, 0, 10);
  if (!(a.max_distance > 0)) r.fail("max_distance", "must be positive (a fraction of the spheres' longest side, e.g. 0.7)");
  a.grid = static_cast<int>(r.integer("grid", a.grid, 4, 512));
  a.rays = static_cast<int>(r.integer("rays", a.rays, 1, 65536));
  r.finish();
  return a;
}

// One line for every key of `section` ("shadows" or "ambient") that none of the scene's chosen
// techniques reads: the key, the techniques, and the techniques that would read it.
void note_unread_keys(const nlohmann::json& j, const std::string& section, TechniqueFamily family,
                      const std::vector<std::string>& chosen, std::vector<std::string>& notes) {
  if (!j.is_object()) return;
  for (const auto& [key, value] : j.items()) {
    if (key == "technique" || value.is_null()) continue;
    if (family == TechniqueFamily::Shadow) {  // shadows.volumes, .spheres, ...: read by the reader itself
      bool kind_key = false;
      for (int i = 0; i < kObjectKinds; ++i) kind_key = kind_key || key == to_string(static_cast<ObjectKind>(i));
      if (kind_key) continue;
    }
    bool read = false;
    for (const auto& name : chosen)
      if (const TechniqueInfo* info = find_technique(family, name))
        read = read || std::find(info->keys.begin(), info->keys.end(), key) != info->keys.end();
    if (read) continue;
    std::vector<std::string> readers;
    for (const auto& t : technique_catalog())
      if (t.family == family && std::find(t.keys.begin(), t.keys.end(), key) != t.keys.end()) readers.emplace_back(t.name);
    notes.push_back(section + "." + key + " is not read by " + (chosen.empty() ? std::string("any technique of this scene") : join(chosen)) +
                    "; " + (readers.empty() ? std::string("no technique reads it") : "it is read by: " + join(readers)));
  }
}

ShadingParams read_shading(const nlohmann::json& j) {
  JsonReader r(j, "shading");
  ShadingParams s;
  s.ambient = r.number("ambient", s.ambient, 0, 1);
  s.diffuse = r.number("diffuse", s.diffuse, 0, 1);
  s.specular = r.number("specular", s.specular, 0, 1);
  s.shininess = r.number("shininess", s.shininess, 1, 1000);
  r.finish();
  return s;
}

const nlohmann::json& array_at(JsonReader& r, const std::string& key) {
  const auto& a = r.raw(key);
  if (!a.is_array()) r.fail(key, "expected an array, got " + json_brief(a));
  return a;
}

}  // namespace

void validate_scene(const Scene& s) {
  auto fail = [](const std::string& key, const std::string& what) { throw Error(key + ": " + what); };
  // what the readers check object by object, for scenes built in code
  for (std::size_t i = 0; i < s.isosurfaces.size(); ++i) {
    const IsosurfaceObject& o = s.isosurfaces[i];
    const std::string key = "isosurfaces." + std::to_string(i);
    if (o.volume >= s.volumes.size()) fail(key + ".volume", "index " + std::to_string(o.volume) + " but the scene has " + std::to_string(s.volumes.size()) + " volume(s)");
    const Volume& v = *s.volumes[o.volume].volume;
    if (!(o.value > v.min_value() && o.value <= v.max_value()))
      fail(key + ".value", num(o.value) + " is outside the data range (" + num(v.min_value()) + ", " + num(v.max_value()) + "]: the isosurface would be empty");
  }
  for (std::size_t i = 0; i < s.volumes.size(); ++i)
    if (!s.volumes[i].volume) fail("volumes." + std::to_string(i), "has no data");
  for (std::size_t i = 0; i < s.particles.size(); ++i)
    if (!s.particles[i].set || s.particles[i].set->size() == 0) fail("particles." + std::to_string(i), "holds no particles");
  for (std::size_t i = 0; i < s.lights.size(); ++i)
    if (s.lights[i].type != LightType::Point && length(s.lights[i].direction) == 0)
      fail("lights." + std::to_string(i) + ".direction", "must not be the zero vector");
  if (length(s.camera.eye - s.camera.target) == 0) fail("camera.eye", "must differ from target");
  if (!find_technique(TechniqueFamily::Shadow, s.shadows.technique))
    fail("shadows.technique", "unknown technique '" + s.shadows.technique + "' (expected one of: " + join(technique_names(TechniqueFamily::Shadow)) + ")");
  if (!find_technique(TechniqueFamily::Ambient, s.ambient.technique))
    fail("ambient.technique", "unknown technique '" + s.ambient.technique + "' (expected one of: " + join(technique_names(TechniqueFamily::Ambient)) + ")");
  auto kinds_of = [](KindMask mask) {
    std::vector<std::string> kinds;
    for (int i = 0; i < kObjectKinds; ++i)
      if (mask & kind_bit(static_cast<ObjectKind>(i))) kinds.push_back(to_string(static_cast<ObjectKind>(i)));
    return join(kinds);
  };
  if (needs_extinction_sat(s) && !s.visible_volume())
    fail(s.shadows.technique == "sat_cone" ? "shadows" : "ambient",
           "the extinction techniques (sat_cone, sat_shells, sampled_ao) need a visible volume");
  // shadows.technique must take at least one kind of caster the scene has (the others get their
  // defaults or shadows.<kind>)
  const TechniqueInfo* shadow = find_technique(TechniqueFamily::Shadow, s.shadows.technique);
  const KindMask casting = casting_kinds(s);
  if (shadow && casting != 0 && !(shadow->casters & casting))
    fail("shadows", "technique '" + s.shadows.technique + "' is for " + kinds_of(shadow->casters) + "; this scene's casters are " +
                          kinds_of(casting) + " (each kind can name its own technique: shadows." + to_string(ObjectKind::Volume) +
                          ", shadows.spheres, shadows.isosurfaces, shadows.planes)");
  const TechniqueInfo* ambient = find_technique(TechniqueFamily::Ambient, s.ambient.technique);
  if (ambient && s.ambient.technique != "none" && ambient_occluders(s) == 0)
    fail("ambient", "technique '" + s.ambient.technique + "' is for " + kinds_of(ambient->casters) + " (its occluders); the scene has none");
  int visible = 0;
  for (const auto& v : s.volumes) visible += v.visible ? 1 : 0;
  if (needs_extinction_sat(s) && visible > 1)
    fail("volumes", "the extinction techniques (sat_cone, sat_shells, sampled_ao) read one volume's summed area table; "
                      "the scene has " + std::to_string(visible) + " visible volumes");
}

std::shared_ptr<Volume> SceneDataCache::volume(const std::string& key, const std::function<Volume()>& load) {
  used_.insert("v" + key);
  auto& v = volumes_[key];
  if (!v) v = std::make_shared<Volume>(load());
  return v;
}

std::shared_ptr<const ParticleSet> SceneDataCache::particles(const std::string& key, const std::function<ParticleSet()>& load) {
  used_.insert("p" + key);
  auto& p = particles_[key];
  if (!p) p = std::make_shared<const ParticleSet>(load());
  return p;
}

const SeriesGrid& SceneDataCache::series(const std::string& key, const Volume& step, const std::string& file) {
  used_.insert("s" + key);
  auto it = series_.find(key);
  if (it == series_.end())
    it = series_.emplace(key, SeriesGrid{step.dims(), step.type(), step.spacing(), step.origin(), step.min_value(),
                                         step.max_value(), file}).first;
  return it->second;
}

double& SceneDataCache::frame_time_ps(const std::string& key) {
  used_.insert("f" + key);
  return frame_times_[key];
}

TrajectoryReader& SceneDataCache::trajectory(const std::string& key, const std::function<std::unique_ptr<TrajectoryReader>()>& open) {
  used_.insert("r" + key);
  auto& t = trajectories_[key];
  if (!t) t = open();
  return *t;
}

const nlohmann::json& SceneDataCache::chosen_transfer_function(const std::string& key, const Volume& volume) {
  used_.insert("t" + key);
  auto& tf = transfer_functions_[key];
  if (tf.is_null()) tf = chooser_ ? chooser_(volume) : choose_transfer_function(volume);
  return tf;
}

void SceneDataCache::set_transfer_function_chooser(std::function<nlohmann::json(const Volume&)> chooser) {
  chooser_ = std::move(chooser);
  transfer_functions_.clear();
}

void SceneDataCache::for_each_volume(const std::function<void(Volume&)>& f) {
  for (auto& [key, volume] : volumes_) f(*volume);
}

void SceneDataCache::drop_unused() {
  std::erase_if(volumes_, [&](const auto& e) { return !used_.count("v" + e.first); });
  std::erase_if(transfer_functions_, [&](const auto& e) { return !used_.count("t" + e.first); });
  std::erase_if(particles_, [&](const auto& e) { return !used_.count("p" + e.first); });
  std::erase_if(trajectories_, [&](const auto& e) { return !used_.count("r" + e.first); });
  std::erase_if(frame_times_, [&](const auto& e) { return !used_.count("f" + e.first); });
  std::erase_if(series_, [&](const auto& e) { return !used_.count("s" + e.first); });
  used_.clear();
}

nlohmann::json with_files_relative_to(nlohmann::json document, const std::string& from_folder, const std::string& to_folder) {
  const std::filesystem::path from = std::filesystem::absolute(from_folder.empty() ? "." : from_folder);
  const std::filesystem::path to = std::filesystem::absolute(to_folder.empty() ? "." : to_folder).lexically_normal();
  auto relocate_one = [&](nlohmann::json& name) {
    if (!name.is_string()) return;
    const std::filesystem::path file = (from / name.get<std::string>()).lexically_normal();  // an absolute file stays itself
    name = file.lexically_relative(to).generic_string();
  };
  auto relocate = [&](nlohmann::json& object, const char* key) {  // a file name, a pattern or a list of them
    if (!object.is_object() || !object.contains(key)) return;
    if (object[key].is_array())
      for (auto& name : object[key]) relocate_one(name);
    else
      relocate_one(object[key]);
  };
  for (const char* kind : {"volumes", "particles"}) {
    if (!document.contains(kind) || !document[kind].is_array()) continue;
    for (auto& object : document[kind]) {
      if (!object.is_object()) continue;
      for (const char* key : {"file", "files", "trajectory"}) relocate(object, key);
      if (object.contains("procedural")) relocate(object["procedural"], "file");
      for (const char* tf : {"transfer_function", "shadow_transfer_function", "color_map"})
        if (object.contains(tf)) relocate(object[tf], "paraview");
    }
  }
  return document;
}

nlohmann::json read_json_file(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path + ": cannot open the file");
  std::ostringstream text;
  text << in.rdbuf();
  return parse_json_text(text.str(), path + ": not valid JSON");
}

void apply_override(nlohmann::json& scene, const std::string& path, const std::string& value) {
  if (path.empty()) throw Error("--set: empty key");
  check_utf8(path, "--set: the key");
  set_path(scene, path, override_value(value, "--set " + path));
}

void set_path(nlohmann::json& scene, const std::string& path, nlohmann::json parsed) {
  if (path.empty()) throw Error("--set: empty key");
  nlohmann::json* node = &scene;
  std::string walked;
  std::size_t start = 0;
  while (true) {
    const std::size_t dot = path.find('.', start);
    const std::string part = path.substr(start, dot == std::string::npos ? std::string::npos : dot - start);
    if (part.empty()) throw Error("--set " + path + ": empty path component");
    walked += (walked.empty() ? "" : ".") + part;
    nlohmann::json* next = nullptr;
    if (node->is_array()) {
      std::size_t idx = 0;
      try {
        std::size_t used = 0;
        idx = std::stoul(part, &used);
        if (used != part.size()) throw std::invalid_argument(part);
      } catch (const std::exception&) {
        throw Error("--set " + path + ": '" + walked + "' indexes an array (expected a number)");
      }
      if (idx >= node->size())
        throw Error("--set " + path + ": '" + walked + "' is past the end of an array of " + std::to_string(node->size()));
      next = &(*node)[idx];
    } else {
      if (node->is_null()) *node = nlohmann::json::object();
      if (!node->is_object()) throw Error("--set " + path + ": '" + walked + "' is inside a value that is not an object");
      next = &(*node)[part];
    }
    if (dot == std::string::npos) {
      *next = std::move(parsed);
      return;
    }
    node = next;
    start = dot + 1;
  }
}

void apply_override(nlohmann::json& scene, const std::string& assignment) {
  const std::size_t eq = assignment.find('=');
  if (eq == std::string::npos) throw Error("--set '" + assignment + "': expected key=value");
  apply_override(scene, assignment.substr(0, eq), assignment.substr(eq + 1));
}

Scene build_scene(const nlohmann::json& j, const std::string& base_dir, const SceneReadOptions& options) {
  JsonReader r(j, "");
  Scene s;
  s.time = static_cast<std::size_t>(r.integer("time", 0, 0, INT32_MAX));
  if (r.has("volumes")) {
    const auto& vols = array_at(r, "volumes");
    for (std::size_t i = 0; i < vols.size(); ++i)
      s.volumes.push_back(read_volume(vols[i], "volumes." + std::to_string(i), base_dir, options, s.time));
  }
  if (r.has("particles")) {
    const auto& parts = array_at(r, "particles");
    for (std::size_t i = 0; i < parts.size(); ++i)
      s.particles.push_back(read_particles(parts[i], "particles." + std::to_string(i), base_dir, options, s.time));
  }
  s.sphere_rasterizer = with_context("sphere_renderer", [&] { return sphere_rasterizer_from_string(r.string("sphere_renderer", "splat")); });
  if (r.has("isosurfaces")) {
    const auto& isos = array_at(r, "isosurfaces");
    for (std::size_t i = 0; i < isos.size(); ++i)
      s.isosurfaces.push_back(read_isosurface(isos[i], "isosurfaces." + std::to_string(i), s.volumes));
  }
  if (r.has("planes")) {
    const auto& planes = array_at(r, "planes");
    for (std::size_t i = 0; i < planes.size(); ++i) s.planes.push_back(read_plane(planes[i], "planes." + std::to_string(i)));
  }
  const Box3 bounds = s.caster_bounds();
  if (r.has("lights")) {
    const auto& lights = array_at(r, "lights");
    for (std::size_t i = 0; i < lights.size(); ++i)
      s.lights.push_back(read_light(lights[i], "lights." + std::to_string(i), bounds));
  } else {
    s.lights.push_back(read_light(nlohmann::json::object(), "lights.0", bounds));  // one light from above
  }
  s.camera = read_camera(r.has("camera") ? r.raw("camera") : nlohmann::json::object(), bounds);
  if (r.has("shadows")) s.shadows = read_shadows(r.raw("shadows"));
  if (r.has("ambient")) s.ambient = read_ambient(r.raw("ambient"));
  if (r.has("shading")) s.shading = read_shading(r.raw("shading"));
  if (r.has("light_cache")) {
    JsonReader lc(r.raw("light_cache"), "light_cache");
    s.light_cache.resolution = static_cast<int>(lc.integer("resolution", s.light_cache.resolution, kMinSatResolution, kMaxSatResolution));
    lc.finish();
  }
  validate_scene(s);
  s.background = r.color("background", s.background);
  r.finish();
  if (r.has("shadows")) {
    std::vector<std::string> used;
    for (const auto& a : shadow_assignments(s)) used.push_back(a.technique);
    note_unread_keys(j["shadows"], "shadows", TechniqueFamily::Shadow, used, s.unread_keys);
  }
  if (r.has("ambient")) note_unread_keys(j["ambient"], "ambient", TechniqueFamily::Ambient, {s.ambient.technique}, s.unread_keys);
  if (r.has("light_cache") && !needs_extinction_sat(s))
    s.unread_keys.push_back("light_cache is not read: only the extinction techniques (sat_cone, sat_shells, sampled_ao) use it");
  if (options.strict && !s.unread_keys.empty()) {
    std::string all;
    for (const auto& n : s.unread_keys) all += "\n  " + n;
    throw Error("keys that the chosen techniques do not read (--strict):" + all);
  }
  return s;
}

Scene load_scene(const std::string& path, const std::vector<std::string>& overrides, const SceneReadOptions& options) {
  nlohmann::json j = read_json_file(path);
  with_context(path, [&] { for (const auto& o : overrides) apply_override(j, o); });
  const std::string base = std::filesystem::path(path).parent_path().string();
  return with_context(path, [&] { return build_scene(j, base, options); });
}

}  // namespace penumbra
