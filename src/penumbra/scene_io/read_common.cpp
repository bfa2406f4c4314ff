// What every section of the scene-file reader shares: joined names, paths resolved against the scene
// file's folder, the shadow flags, the key that identifies an object's data, its one source.
#include "penumbra/scene_io/scene_sections.h"

#include <algorithm>
#include <filesystem>

namespace penumbra::scene_sections {

std::string join(const std::vector<std::string>& names) {
  std::string s;
  for (const auto& n : names) s += (s.empty() ? "" : ", ") + n;
  return s;
}

std::string resolve(const std::string& base_dir, const std::string& file) {
  const std::filesystem::path p(file);
  return p.is_absolute() || base_dir.empty() ? file : (std::filesystem::path(base_dir) / p).string();
}

// casts_shadows / receives_shadows (default true) and clip (default true; planes false) of any object
// that is drawn.
void read_shadow_flags(JsonReader& r, ShadowFlags& f) {
  f.casts_shadows = r.boolean("casts_shadows", f.casts_shadows);
  f.receives_shadows = r.boolean("receives_shadows", f.receives_shadows);
  f.clip = r.boolean("clip", f.clip);
}

// What defines an object's data (the keys `keys` of it, with the folder relative files resolve against).
std::string data_key(const nlohmann::json& j, const std::string& base_dir, std::initializer_list<const char*> keys, bool all_but) {
  nlohmann::json k = nlohmann::json::object();
  k["base_dir"] = base_dir;
  for (const auto& item : j.items()) {
    const std::string& key = item.key();
    const bool listed = std::find_if(keys.begin(), keys.end(), [&](const char* n) { return key == n; }) != keys.end();
    if (listed != all_but) k[key] = item.value();
  }
  return k.dump();
}

// Exactly one of the keys that say where an object's data comes from (volumes may give "files").
void require_one_source(JsonReader& r) {
  const int sources = int(r.has("file")) + int(r.has("procedural")) + int(r.has("array")) + int(r.has("files"));
  if (sources != 1)
    r.fail(r.has("file") ? "file" : r.has("procedural") ? "procedural" : r.has("array") ? "array" : "files",
           sources == 0 ? "missing: give 'file' or 'procedural'"
                        : "give exactly one of 'file', 'files', 'procedural' and 'array'");
}

}  // namespace penumbra::scene_sections
