// Reading the scene file (JSON, docs/scene-file.md) and the command line's `--set key=value` overrides.
#pragma once

#include <nlohmann/json.hpp>

#include <string>
#include <utility>
#include <vector>

#include "penumbra/scene/scene.h"

namespace penumbra {

// Parses a JSON file; syntax errors name the file, line and column.
nlohmann::json read_json_file(const std::string& path);

// Applies `--set path=value`: path is dotted (array elements by index, "lights.0.intensity"); value is
// parsed as JSON when it is valid JSON, else taken as a string. Missing object keys are created (the
// scene reader then rejects names it does not know); an index past an array's end is an error.
void apply_override(nlohmann::json& scene, const std::string& path, const std::string& value);
void apply_override(nlohmann::json& scene, const std::string& assignment);  // "path=value"

struct SceneReadOptions {
  // Keys that the chosen techniques do not read (Scene::unread_keys) are an error, not a note.
  bool strict = false;
};

// Builds the scene; relative file paths are resolved against base_dir. Every error names the key.
// Keys of `shadows`, `ambient` and `light_cache` that the chosen techniques do not read are listed in
// the scene's unread_keys (technique_catalog.h says who reads what).
Scene build_scene(const nlohmann::json& scene, const std::string& base_dir, const SceneReadOptions& options = {});

// read_json_file + overrides + build_scene, with the file name prepended to errors.
Scene load_scene(const std::string& path, const std::vector<std::string>& overrides = {}, const SceneReadOptions& options = {});

}  // namespace penumbra
