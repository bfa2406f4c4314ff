// The scene file's shadows, ambient and shading sections: the technique names and keys the catalogue
// (registry/technique_catalog.h) knows, and a note for every key no chosen technique reads.
#include "penumbra/scene_io/scene_sections.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

#include "penumbra/registry/technique_catalog.h"

namespace penumbra::scene_sections {
namespace {

void check_technique(JsonReader& r, const std::string& name, const std::vector<std::string>& available) {
  if (std::find(available.begin(), available.end(), name) != available.end()) return;
  r.fail("technique", "unknown technique '" + name + "' (expected one of: " + join(available) + ")");
}

bool is_kind_key(const std::string& key) {
  for (int i = 0; i < kObjectKinds; ++i)
    if (key == to_string(static_cast<ObjectKind>(i))) return true;
  return false;
}

// A value of `key` as its declaration's type: a choice's string, an integer (an integral number such
// as 512.0, which JSON writers and Python floats produce, counts), or any number.
ParamValue parse_param(JsonReader& r, const std::string& key, const ParamSpec& spec, const nlohmann::json& v) {
  const std::string expected = "expected " + (spec.type == ParamType::Choice ? spec.allowed_text()
                                               : (spec.type == ParamType::Integer ? "an integer" : "a number") + std::string(" (") + spec.allowed_text() + ")");
  switch (spec.type) {
    case ParamType::Choice:
      if (v.is_string()) return v.get<std::string>();
      break;
    case ParamType::Integer:
      if (v.is_number_unsigned() && v.get<std::uint64_t>() > static_cast<std::uint64_t>(INT64_MAX)) r.fail(key, json_brief(v) + ": out of range (" + expected + ")");
      if (v.is_number_integer()) return v.get<std::int64_t>();
      if (v.is_number_float() && std::floor(v.get<double>()) == v.get<double>() && std::abs(v.get<double>()) < 9e15)
        return static_cast<std::int64_t>(v.get<double>());
      break;
    case ParamType::Number:
      if (v.is_number()) return v.get<double>();
      break;
  }
  r.fail(key, expected + ", got " + json_brief(v));
}

// Every other key of the section: checked against the declaration the family's techniques share
// (type, range, allowed values) and kept in `params`; null means the default. A key no technique of
// the family declares is an error naming the keys they do.
void read_params(JsonReader& r, const nlohmann::json& j, TechniqueFamily family, TechniqueParams& params) {
  for (const auto& [key, value] : j.items()) {
    if (key == "technique" || (family == TechniqueFamily::Shadow && is_kind_key(key))) continue;
    const ParamSpec* spec = find_param(family, key);
    if (!spec) {
      std::vector<std::string> keys{"technique"};
      for (const ParamSpec* p : family_params(family)) keys.push_back(p->key);
      if (family == TechniqueFamily::Shadow)
        for (int i = 0; i < kObjectKinds; ++i) keys.push_back(to_string(static_cast<ObjectKind>(i)));
      r.fail(key, "unknown key (expected one of: " + join(keys) + ")");
    }
    if (!r.has(key)) continue;  // null: the default
    ParamValue parsed = parse_param(r, key, *spec, r.raw(key));
    if (const std::string problem = spec->check(parsed); !problem.empty()) r.fail(key, json_brief(value) + ": " + problem);
    params.set(key, std::move(parsed));
  }
}

// The declared defaults of the family's keys that `j` leaves out (every key a technique of the family
// declares, read or not by the chosen one), noted for Engine::get.
void note_param_defaults(const nlohmann::json& j, const std::string& section, TechniqueFamily family) {
  for (const ParamSpec* p : family_params(family)) {
    if (j.contains(p->key) && !j[p->key].is_null()) continue;
    if (p->type == ParamType::Choice) note_default(section + "." + p->key, p->default_choice);
    else if (p->type == ParamType::Integer) note_default(section + "." + p->key, static_cast<std::int64_t>(p->default_number));
    else note_default(section + "." + p->key, p->default_number);
  }
}

}  // namespace

ShadowSettings read_shadows(const nlohmann::json& j) {
  JsonReader r(j, "shadows");
  ShadowSettings s;
  s.technique = r.string("technique", s.technique);
  check_technique(r, s.technique, technique_names(TechniqueFamily::Shadow));
  read_params(r, j, TechniqueFamily::Shadow, s.params);
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
  note_param_defaults(j, "shadows", TechniqueFamily::Shadow);
  r.finish();
  return s;
}

AmbientSettings read_ambient(const nlohmann::json& j) {
  JsonReader r(j, "ambient");
  AmbientSettings a;
  a.technique = r.string("technique", a.technique);
  check_technique(r, a.technique, technique_names(TechniqueFamily::Ambient));
  read_params(r, j, TechniqueFamily::Ambient, a.params);
  note_param_defaults(j, "ambient", TechniqueFamily::Ambient);
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
      if (const TechniqueInfo* info = find_technique(family, name)) read = read || info->reads(key);
    if (read) continue;
    std::vector<std::string> readers;
    for (const TechniqueInfo* t : technique_catalog())
      if (t->family == family && t->reads(key)) readers.push_back(t->name);
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

}  // namespace penumbra::scene_sections
