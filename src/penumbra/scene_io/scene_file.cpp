#include "penumbra/scene_io/scene_file.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "penumbra/accel/extinction_sat.h"
#include "penumbra/core/byte_size.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/registry/technique_catalog.h"
#include "penumbra/scene_io/json_reader.h"
#include "penumbra/scene_io/scene_sections.h"

namespace penumbra {
using namespace scene_sections;
namespace {

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
  // The default light (a scene without "lights" has one, {}: directional from above) is edited like any
  // other: lights.0.direction on such a scene makes it the document's first entry (lights.1 is past the
  // end of that array).
  if (path.size() > 7 && path.rfind("lights.", 0) == 0 && path[7] >= '0' && path[7] <= '9' && scene.is_object() &&
      (!scene.contains("lights") || scene["lights"].is_null()))
    scene["lights"] = nlohmann::json::array({nlohmann::json::object()});
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
  const RecordDefaults recording(options.defaults);
  JsonReader r(j, "");
  Scene s;
  s.time = static_cast<std::size_t>(r.integer("time", 0, 0, INT32_MAX));
  if (r.has("memory_budget")) {
    const nlohmann::json& b = r.raw("memory_budget");
    if (b.is_number_integer() && b.get<std::int64_t>() > 0) s.memory_budget = static_cast<std::uint64_t>(b.get<std::int64_t>());
    else if (b.is_string()) s.memory_budget = with_context("memory_budget", [&] { return parse_byte_size(b.get<std::string>()); });
    else r.fail("memory_budget", json_brief(b) + " (expected bytes, or a size such as \"4G\" or \"512M\")");
  }
  if (r.has("volumes")) {
    const auto& vols = array_at(r, "volumes");
    std::uint64_t budget_left = s.memory_budget;
    for (std::size_t i = 0; i < vols.size(); ++i)
      s.volumes.push_back(read_volume(vols[i], "volumes." + std::to_string(i), base_dir, options, s.time,
                                      s.memory_budget > 0 ? &budget_left : nullptr));
    if (s.memory_budget > 0) s.refinement_bytes = budget_left;
    else if (std::any_of(s.volumes.begin(), s.volumes.end(), [](const VolumeObject& v) { return v.pyramid != nullptr; })) {
      std::uint64_t held = 0;  // what chose the levels: a quarter of this machine's memory
      for (const VolumeObject& v : s.volumes) {
        const auto& d = v.volume->dims();
        held += volume_held_bytes({d[0], d[1], d[2]}, v.volume->type());
      }
      const std::uint64_t quarter = default_pyramid_budget();
      s.refinement_bytes = quarter > held ? quarter - held : 0;
    }
  }
  if (r.has("particles")) {
    const auto& parts = array_at(r, "particles");
    SceneDataCache files_of_this_scene;
    SceneDataCache& files = options.cache ? *options.cache : files_of_this_scene;
    for (std::size_t i = 0; i < parts.size(); ++i)
      s.particles.push_back(read_particles(parts[i], "particles." + std::to_string(i), base_dir, options, s.time, files));
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
  s.first_slice = s.planes.size();
  if (r.has("slices")) {
    const auto& slices = array_at(r, "slices");
    for (std::size_t i = 0; i < slices.size(); ++i)
      s.planes.push_back(read_slice(slices[i], "slices." + std::to_string(i), s.volumes, base_dir));
  }
  if (r.has("clip_planes")) s.clip_planes = read_clip_planes(r.raw("clip_planes"), "clip_planes");
  for (Plane& p : s.planes) p.clip_planes = s.clip_planes_for(p.clip);
  const Box3 bounds = s.caster_bounds();
  if (r.has("lights")) {
    const auto& lights = array_at(r, "lights");
    for (std::size_t i = 0; i < lights.size(); ++i)
      s.lights.push_back(read_light(lights[i], "lights." + std::to_string(i), bounds));
  } else {
    s.lights.push_back(read_light(nlohmann::json::object(), "lights.0", bounds));  // one light from above
  }
  s.camera = read_camera(r.has("camera") ? r.raw("camera") : nlohmann::json::object(), bounds);
  // Absent sections are read as empty objects: the same settings, and their defaults noted.
  const nlohmann::json empty = nlohmann::json::object();
  s.shadows = read_shadows(r.has("shadows") ? r.raw("shadows") : empty);
  s.ambient = read_ambient(r.has("ambient") ? r.raw("ambient") : empty);
  s.shading = read_shading(r.has("shading") ? r.raw("shading") : empty);
  {
    JsonReader lc(r.has("light_cache") ? r.raw("light_cache") : empty, "light_cache");
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
