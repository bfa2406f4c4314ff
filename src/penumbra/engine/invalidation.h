// What an edit makes stale: one declarative table from scene paths (the dotted paths of `--set`) to
// the renderer's cached structures (render/renderer.h names them), and one table of the structures
// that hang off others. An edit's stale set is the closure, over the second table, of what the first
// declares for its path; the renderer rebuilds exactly that (plus what the edited scene newly needs or
// no longer has, and what depends on that). docs/engine.md prints both tables.
#pragma once

#include <string>
#include <vector>

#include "penumbra/scene/scene.h"

namespace penumbra {

// A row: the paths it covers ('#' matches an array index, and a row covers every path below its own
// unless a longer row matches) and the structures an edit there makes stale. In structure names '#'
// is the edited element's index and '*' every element's; "scene" means everything (a new renderer).
struct InvalidationRule {
  const char* path;
  std::vector<const char*> stale;
  const char* why;
};
const std::vector<InvalidationRule>& invalidation_table();

// A structure and the structures built from it (same '#' and '*' conventions).
struct Dependency {
  const char* structure;
  std::vector<const char*> dependents;
};
const std::vector<Dependency>& dependency_table();

// The row that covers `path` (the longest matching one), or nullptr when no row does.
const InvalidationRule* invalidation_rule(const std::string& path);

// The structures an edit of `path` makes stale in `scene` (the edited scene), with '#' and '*'
// expanded and closed over the dependency table; {"scene"} when it needs a new renderer. Error naming
// the path when no row covers it.
std::vector<std::string> invalidated_by(const std::string& path, const Scene& scene);

// True when every path edits how the scene is lit or shaded (lights, shadows, ambient, light_cache,
// shading, background), not what the camera sees: the renderer keeps the surfaces it listed.
bool lighting_only(const std::vector<std::string>& paths);

// `names` and every structure built from them (the dependency table's closure), for `scene`.
std::vector<std::string> with_dependents(const std::vector<std::string>& names, const Scene& scene);

}  // namespace penumbra
