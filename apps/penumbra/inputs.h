// What `render` (and later `view`) open: one scene file, or data files (volumes, molecules) that make a
// scene of their own (scene_io/data_scene.h), with `--set` overrides and the layout of .raw volumes.
#pragma once

#include <CLI/CLI.hpp>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "penumbra/data/io/volume_io.h"
#include "penumbra/distributed/brick_reading.h"
#include "penumbra/engine/engine.h"

namespace penumbra::cli {

struct InputOptions {
  std::vector<std::string> inputs;  // a scene .json, or data files
  std::vector<std::string> sets;    // --set path=value
  bool strict = false;
  // the layout of .raw volumes
  std::vector<std::int64_t> raw_dims;
  std::string raw_type, raw_endian = "little";
  std::vector<float> raw_spacing;
  std::uint64_t raw_header_bytes = 0;
  VolumeLoadOptions choice;  // which part of a volume file: --series, --channel, --level, --dataset, --grid
  std::string memory_budget;  // --memory-budget: the scene's memory_budget ("" keeps the scene's)
};

// --series, --channel, --level, --dataset and --grid, into `choice` (render, view, info, convert).
void add_volume_choice_options(CLI::App& cmd, VolumeLoadOptions& choice);
// Whether any of them was given.
bool chooses_part(const VolumeLoadOptions& choice);

// Adds the positional inputs, the --raw-* options, --series, --channel, --level, --dataset and --grid to a subcommand.
void add_input_options(CLI::App& cmd, InputOptions& o);

// The engine over the inputs; `extra_sets` go before the user's --set (e.g. --width). Errors name the
// file or option.
Engine open_inputs(const InputOptions& o, const std::vector<std::string>& extra_sets = {});
// When the inputs are one scene file: its document, `extra_sets` then the user's --set applied, and the
// folder its relative paths resolve against (what open_inputs builds; a distributed render builds it
// on every rank, distributed/brick_reading.h). Errors name the file or option.
struct SceneDocument {
  nlohmann::json document;
  std::string base_dir;
};
std::optional<SceneDocument> scene_file_document(const InputOptions& o, const std::vector<std::string>& extra_sets = {});

// When the inputs are data files (not a scene file): their scene document before anything is loaded
// (scene_io/data_scene.h data_scene_inputs) and what completes it from the scene it loads
// (complete_data_scene, then `extra_sets` and the user's --set) — how a distributed render reads them
// as bricks (distributed/brick_reading.h). Errors name the file or option.
struct DataFilesDocument {
  nlohmann::json document;
  DocumentCompletion complete;
};
DataFilesDocument data_files_document(const InputOptions& o, const std::vector<std::string>& extra_sets = {});

// Error unless `path` can name a scene file to write: a .json in an existing folder.
void check_scene_file_path(const std::string& path);

// Writes the engine's scene as a scene file (Engine::saved_document): JSON, paths relative to its folder.
void write_scene_file(const Engine& engine, const std::string& path);

}  // namespace penumbra::cli
