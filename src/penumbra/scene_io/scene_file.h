// Reading the scene file (JSON, docs/scene-file.md) and the command line's `--set key=value` overrides.
#pragma once

#include <nlohmann/json.hpp>

#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "penumbra/data/io/particle_io.h"
#include "penumbra/scene_io/json_reader.h"
#include "penumbra/data/io/trajectory_io.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

// Parses a JSON file; syntax errors name the file, line and column.
nlohmann::json read_json_file(const std::string& path);

// Applies `--set path=value`: path is dotted (array elements by index, "lights.0.intensity"); value is
// parsed as JSON when it is valid JSON, else taken as a string. Missing object keys are created (the
// scene reader then rejects names it does not know); an index past an array's end is an error.
void apply_override(nlohmann::json& scene, const std::string& path, const std::string& value);
void apply_override(nlohmann::json& scene, const std::string& assignment);  // "path=value"
// The same walk with a JSON value (what the engine's edits use).
void set_path(nlohmann::json& scene, const std::string& path, nlohmann::json value);

// The document with every file it names (volumes, particles, a molecular-density's molecule, ParaView
// colour maps) resolved against `from_folder` and made relative to `to_folder`: what a scene saved in
// `to_folder` must say to name the same files.
nlohmann::json with_files_relative_to(nlohmann::json document, const std::string& from_folder, const std::string& to_folder);

// What a volume series (volumes[].files, a generated series) keeps of the first step it loaded.
struct SeriesGrid {
  std::array<int, 3> dims;
  ScalarType type;
  Vec3 spacing, origin;
  float min_value, max_value;  // the transfer function's range for every step
  std::string file;
};

// The volumes and particle sets a scene read loaded, by what defines them (the file and its reading
// options, or the generator and its parameters), so that reading an edited scene again loads only the
// data whose definition changed (engine/engine.h).
class SceneDataCache {
public:
  std::shared_ptr<Volume> volume(const std::string& key, const std::function<Volume()>& load);
  std::shared_ptr<const ParticleSet> particles(const std::string& key, const std::function<ParticleSet()>& load);
  // An open trajectory (its frame index built once), so that moving to another frame reads only that frame.
  TrajectoryReader& trajectory(const std::string& key, const std::function<std::unique_ptr<TrajectoryReader>()>& open);
  double& frame_time_ps(const std::string& key);  // the time (ps) of the frame cached under `key`
  // A particle file read once (by path) for every particle set built from it.
  std::shared_ptr<const ParticleFile> particle_file(const std::string& path, const std::function<std::shared_ptr<const ParticleFile>()>& read);
  // The atoms a selection kept for the spheres cached under `key` (none: no selection).
  std::optional<std::size_t>& selected_atoms(const std::string& key);
  // The atom indices a trajectory's selection that does not depend on positions keeps, evaluated once.
  std::shared_ptr<const std::vector<std::uint32_t>> selected_indices(const std::string& key,
                                                                     const std::function<std::vector<std::uint32_t>()>& evaluate);
  // A series' reference: `step`'s grid and range when the series is new to the cache, else the stored one.
  const SeriesGrid& series(const std::string& key, const Volume& step, const std::string& file);
  // The transfer function chosen from a volume's data (data/transfer_function_choice.h), once per data.
  const nlohmann::json& chosen_transfer_function(const std::string& key, const Volume& volume);
  // The levels a volume cached under `key` refines from (VolumeObject::pyramid; nullptr: none), found once
  // per data (a file read reduced reads its header for them).
  std::shared_ptr<const PyramidSource> pyramid(const std::string& key, const std::function<std::shared_ptr<const PyramidSource>()>& find);
  // Chooses transfer functions with `chooser` from now on (forgetting those chosen before): for data
  // that one process holds only part of (a distributed volume, chosen from the whole grid's histogram).
  void set_transfer_function_chooser(std::function<nlohmann::json(const Volume&)> chooser);
  // Every volume held, for a caller that completes what one process could not know of it (a window's
  // whole-grid value range).
  void for_each_volume(const std::function<void(Volume&)>& f);
  // Forgets what the reads since the last call did not use.
  void drop_unused();

private:
  std::map<std::string, std::shared_ptr<Volume>> volumes_;
  std::map<std::string, std::shared_ptr<const ParticleSet>> particles_;
  std::map<std::string, std::shared_ptr<TrajectoryReader>> trajectories_;  // shared by copies of the cache
  std::map<std::string, double> frame_times_;
  std::map<std::string, std::shared_ptr<const ParticleFile>> particle_files_;
  std::map<std::string, std::optional<std::size_t>> selected_atoms_;
  std::map<std::string, std::shared_ptr<const std::vector<std::uint32_t>>> selected_indices_;
  std::map<std::string, SeriesGrid> series_;
  std::map<std::string, nlohmann::json> transfer_functions_;
  std::map<std::string, std::shared_ptr<const PyramidSource>> pyramids_;
  std::function<nlohmann::json(const Volume&)> chooser_;  // empty: choose_transfer_function
  std::set<std::string> used_;
};

// Data the caller holds in memory (the Python package's NumPy arrays), named in a scene document by
// `"array": NAME` in place of `"file"` or `"procedural"`. Only a reader given these knows the names.
struct SceneArrays {
  std::map<std::string, std::shared_ptr<const Volume>> volumes;  // views of the caller's voxels (Volume::view)
  std::map<std::string, std::shared_ptr<const ParticleSet>> particles;
  // The bounds the camera and lights frame a particle array by: those of its first spheres, kept when
  // Engine::replace_array moves them (as a trajectory is framed by its topology), so that the camera
  // stays still while a molecule moves. A name without an entry is framed by its current spheres.
  std::map<std::string, Box3> particle_framing;
};

struct SceneReadOptions {
  // Keys that the chosen techniques do not read (Scene::unread_keys) are an error, not a note.
  bool strict = false;
  SceneDataCache* cache = nullptr;  // reuse data loaded before (null: load everything)
  const SceneArrays* arrays = nullptr;  // what "array" names (null: "array" is an error)
  // Reads the volumes named by "file" or "files" (null: load_volume); a rank of a distributed render
  // reads only its brick (distributed/brick_reading.h).
  const std::function<Volume(const std::vector<std::string>& paths, const VolumeLoadOptions& options)>* volume_reader = nullptr;
  // The folder every file that a data file names must lie inside (VolumeLoadOptions::confine_to).
  std::string confine_to{};
  // Where the defaults the read took are noted, by dotted path (null: not noted; json_reader.h).
  ReadDefaults* defaults = nullptr;
};

// Builds the scene; relative file paths are resolved against base_dir. Every error names the key.
// Keys of `shadows`, `ambient` and `light_cache` that the chosen techniques do not read are listed in
// the scene's unread_keys (technique_catalog.h says who reads what).
Scene build_scene(const nlohmann::json& scene, const std::string& base_dir, const SceneReadOptions& options = {});

// The checks across objects that build_scene makes (techniques that fit the scene's kinds, indices in
// range, isovalues inside the data), public for scenes built in code: Error naming the key.
void validate_scene(const Scene& scene);

// read_json_file + overrides + build_scene, with the file name prepended to errors.
Scene load_scene(const std::string& path, const std::vector<std::string>& overrides = {}, const SceneReadOptions& options = {});

}  // namespace penumbra
