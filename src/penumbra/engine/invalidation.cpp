#include "penumbra/engine/invalidation.h"

#include <algorithm>
#include <set>

#include "penumbra/core/error.h"

namespace penumbra {
namespace {

std::vector<std::string> split(const std::string& path) {
  std::vector<std::string> parts;
  std::size_t start = 0;
  while (true) {
    const std::size_t dot = path.find('.', start);
    parts.push_back(path.substr(start, dot == std::string::npos ? std::string::npos : dot - start));
    if (dot == std::string::npos) return parts;
    start = dot + 1;
  }
}

bool is_index(const std::string& s) { return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; }); }

// How many rows (pattern components) of `pattern` match the start of `path`; -1 when it does not.
int match(const std::string& pattern, const std::vector<std::string>& path, std::string& index) {
  const std::vector<std::string> p = split(pattern);
  if (p.size() > path.size()) return -1;
  for (std::size_t i = 0; i < p.size(); ++i) {
    if (p[i] == "#") {
      if (!is_index(path[i])) return -1;
      index = path[i];
    } else if (p[i] != path[i]) {
      return -1;
    }
  }
  return static_cast<int>(p.size());
}

std::size_t count_of(const std::string& kind, const Scene& s) {
  if (kind == "volumes") return s.volumes.size();
  if (kind == "lights") return s.lights.size();
  if (kind == "isosurfaces") return s.isosurfaces.size();
  if (kind == "particles") return s.particles.size();
  if (kind == "planes") return s.planes.size();
  return 0;
}

// "lights.*.shadows" → one name per light; "volumes.#.lut" → with the index.
void expand(const std::string& name, const std::string& index, const Scene& s, std::set<std::string>& out) {
  const std::size_t star = name.find(".*.");
  if (star != std::string::npos) {
    const std::string kind = name.substr(0, star), rest = name.substr(star + 3);
    for (std::size_t i = 0; i < count_of(kind, s); ++i) out.insert(kind + "." + std::to_string(i) + "." + rest);
    return;
  }
  const std::size_t hash = name.find(".#.");
  if (hash != std::string::npos) {
    out.insert(name.substr(0, hash) + "." + index + "." + name.substr(hash + 3));
    return;
  }
  out.insert(name);
}

constexpr const char* kScene = "scene";
constexpr const char* kAllShadows = "lights.*.shadows";
constexpr const char* kTrajectorySpheres = "spheres when a trajectory moves them";
constexpr const char* kCastingSlice = "casters when the slice casts shadows";

}  // namespace

const std::vector<InvalidationRule>& invalidation_table() {
  static const std::vector<InvalidationRule> rows = {
      {"camera", {}, "the view only: every frame draws it anew"},
      {"background", {}, "shading only"},
      {"shading", {}, "shading only"},
      {"sphere_renderer", {}, "how the eye pass finds spheres (a BVH is built if Embree needs one)"},
      {"lights", {kAllShadows}, "lights added or removed: every light's shadows"},
      {"lights.#", {"lights.#.shadows"}, "that light's shadow structures only"},
      {"lights.#.color", {}, "shading only (shadows do not depend on the light's colour)"},
      {"lights.#.intensity", {}, "shading only"},
      {"volumes", {kScene}, "volumes added or removed: a new scene"},
      {"volumes.#", {kScene}, "new data (file, generator, array, spacing, origin) or visibility: a new scene (other data stays loaded)"},
      {"volumes.#.transfer_function", {"volumes.#.lut", "volumes.#.empty_space", "sat", "casters"},
       "the table, the empty cells, the SAT and what casts; not the gradients or the min/max grid"},
      {"volumes.#.shadow_transfer_function", {"sat", "casters"}, "what the volume casts"},
      {"volumes.#.compositing", {"volumes.#.lut", "volumes.#.empty_space", "sat", "casters"}, "as a transfer function"},
      {"volumes.#.step", {"volumes.*.lut"}, "the eye lattice (shared by the visible volumes) and its opacity correction"},
      {"volumes.#.jitter", {}, "the eye lattice's offsets only"},
      {"volumes.#.gradients", {"volumes.#.gradients"}, "the shading normals: stored or freed"},
      {"volumes.#.casts_shadows", {"casters"}, "what casts"},
      {"volumes.#.clip", {"sat", "casters"}, "what the volume casts (the eye pass reads the flag every frame)"},
      {"volumes.#.receives_shadows", {}, "which samples ask for shadows"},
      {"particles", {kScene}, "particle objects added or removed: a new scene"},
      {"particles.#", {"spheres"}, "new spheres (file, generator, array, radius, origin)"},
      {"particles.#.select", {"spheres"}, "other atoms: the spheres and what hangs off them (the file stays read)"},
      {"particles.#.color_by", {"spheres.colors"}, "colours only"},
      {"particles.#.color", {"spheres.colors"}, "colours only"},
      {"particles.#.scalar", {"spheres.colors"}, "colours only"},
      {"particles.#.color_map", {"spheres.colors"}, "colours only"},
      {"particles.#.casts_shadows", {"spheres"}, "the casting spheres come first in the set"},
      {"particles.#.visible", {"spheres"}, "the set joins or leaves the drawn spheres (the file stays read)"},
      {"particles.#.clip", {"spheres.clip"}, "which spheres are cut or removed, and what hangs off them"},
      {"particles.#.receives_shadows", {}, "which surfaces ask for shadows"},
      {"isosurfaces", {kScene}, "isosurfaces added or removed: a new scene"},
      {"isosurfaces.#", {kScene}, "another volume: a new scene"},
      {"isosurfaces.#.value", {"isosurfaces.#.surface"}, "the surface and what it casts; not the min/max hierarchy"},
      {"isosurfaces.#.method", {"isosurfaces.#.mesh"}, "the eye pass (a mesh is extracted when asked for)"},
      {"isosurfaces.#.color", {}, "shading only"},
      {"isosurfaces.#.collapse", {}, "the eye pass only"},
      {"isosurfaces.#.casts_shadows", {"casters"}, "what casts"},
      {"isosurfaces.#.clip", {"casters"}, "what the surface casts (the eye pass reads the flag every frame)"},
      {"isosurfaces.#.receives_shadows", {}, "which surfaces ask for shadows"},
      {"planes", {kScene}, "planes added or removed: a new scene"},
      {"planes.#", {"casters"}, "what casts"},
      {"planes.#.color", {}, "shading only"},
      {"planes.#.clip", {"casters"}, "what the plane casts"},
      {"slices", {kScene}, "slices added or removed: a new scene"},
      {"slices.#", {kCastingSlice}, "the slice is drawn anew every frame; what it casts only when it casts"},
      {"slices.#.casts_shadows", {"casters"}, "what casts"},
      {"clip_planes", {"spheres.clip", "sat", "casters"},
       "the spheres' cut marks, the SAT and every light structure (through the casters); never the gradients or the "
       "min/max grids"},
      {"planes.#.receives_shadows", {}, "which surfaces ask for shadows"},
      {"shadows", {kAllShadows}, "every light's shadow structures (a technique that needs the SAT or a BVH builds it)"},
      {"shadows.step", {"casters"}, "the light rays' lattice"},
      {"ambient", {"ambient"}, "the ambient cache"},
      {"ambient.bleeding", {"sat", "ambient"}, "the SAT holds colour only for colour bleeding"},
      {"light_cache", {"sat"}, "the SAT's grid"},
      {"memory_budget", {kScene}, "what the volumes may hold: a new scene (a pyramid may open at another level, gradients be stored or not)"},
      {"time", {kTrajectorySpheres},
       "another frame: the spheres of every trajectory (and what depends on them: BVH, shadows, AO); a volume "
       "series' next step is new data, so a new scene"},
  };
  return rows;
}

const std::vector<Dependency>& dependency_table() {
  static const std::vector<Dependency> rows = {
      {"spheres", {"spheres.colors", "spheres.clip", "bvh", "casters"}},
      {"spheres.clip", {"bvh", "casters"}},
      {"bvh", {"casters"}},
      {"sat", {"casters"}},
      {"casters", {"ambient", kAllShadows}},
      {"isosurfaces.#.surface", {"isosurfaces.#.mesh", "casters"}},
      {"volumes.#.minmax", {"volumes.#.empty_space", "casters"}},
  };
  return rows;
}

const InvalidationRule* invalidation_rule(const std::string& path) {
  const std::vector<std::string> parts = split(path);
  const InvalidationRule* best = nullptr;
  int best_len = 0;
  for (const auto& row : invalidation_table()) {
    std::string index;
    const int n = match(row.path, parts, index);
    if (n > best_len) {
      best = &row;
      best_len = n;
    }
  }
  return best;
}

std::vector<std::string> with_dependents(const std::vector<std::string>& names, const Scene& scene) {
  std::set<std::string> out(names.begin(), names.end());
  std::vector<std::string> pending(names.begin(), names.end());  // worklist of the closure
  while (!pending.empty()) {
    const std::string name = pending.back();
    pending.pop_back();
    const std::vector<std::string> parts = split(name);
    for (const auto& d : dependency_table()) {
      std::string index;
      if (match(d.structure, parts, index) != static_cast<int>(parts.size()) || split(d.structure).size() != parts.size()) continue;
      std::set<std::string> deps;
      for (const char* dep : d.dependents) expand(dep, index, scene, deps);
      for (const auto& dep : deps)
        if (out.insert(dep).second) pending.push_back(dep);
    }
  }
  return {out.begin(), out.end()};
}

bool lighting_only(const std::vector<std::string>& paths) {
  static const std::set<std::string> kLighting = {"lights", "shadows", "ambient", "light_cache", "shading", "background"};
  return std::all_of(paths.begin(), paths.end(), [](const std::string& path) { return kLighting.count(split(path).front()) > 0; });
}

std::vector<std::string> invalidated_by(const std::string& path, const Scene& scene) {
  const InvalidationRule* row = invalidation_rule(path);
  if (!row) throw Error(path + ": not a scene path (docs/scene-file.md lists the keys; docs/engine.md what each edit rebuilds)");
  std::string index;
  match(row->path, split(path), index);
  std::set<std::string> stale;
  for (const char* s : row->stale) {
    if (std::string(s) == kScene) return {kScene};
    if (std::string(s) == kCastingSlice) {
      const std::size_t slice = scene.first_slice + static_cast<std::size_t>(std::stoul(index));
      if (slice < scene.planes.size() && scene.planes[slice].casts_shadows) stale.insert("casters");
      continue;
    }
    if (std::string(s) == kTrajectorySpheres) {
      if (std::any_of(scene.particles.begin(), scene.particles.end(), [](const ParticleObject& p) { return p.frames > 0; }))
        stale.insert("spheres");
      continue;
    }
    expand(s, index, scene, stale);
  }
  return with_dependents({stale.begin(), stale.end()}, scene);
}

}  // namespace penumbra
