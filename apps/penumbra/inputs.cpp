#include "inputs.h"

#include <filesystem>
#include <fstream>
#include <optional>

#include "penumbra/core/byte_size.h"
#include "penumbra/core/error.h"
#include "penumbra/core/replace_file.h"
#include "penumbra/scene_io/data_scene.h"

namespace penumbra::cli {
namespace {

std::optional<RawVolumeOptions> raw_options(const InputOptions& o) {
  const bool given = !o.raw_dims.empty() || !o.raw_type.empty() || !o.raw_spacing.empty() || o.raw_header_bytes > 0;
  if (!given) return std::nullopt;
  if (o.raw_dims.size() != 3 || o.raw_type.empty()) throw Error("--raw-dims X Y Z and --raw-type go together (the layout of a .raw volume)");
  RawVolumeOptions r;
  for (int a = 0; a < 3; ++a) r.dims[a] = o.raw_dims[static_cast<std::size_t>(a)];
  r.type = with_context("--raw-type", [&] { return scalar_type_from_string(o.raw_type); });
  if (o.raw_endian != "little" && o.raw_endian != "big") throw Error("--raw-endian " + o.raw_endian + " (expected little or big)");
  r.big_endian = o.raw_endian == "big";
  if (!o.raw_spacing.empty()) {
    if (o.raw_spacing.size() != 3) throw Error("--raw-spacing takes three numbers (x y z)");
    r.spacing = {o.raw_spacing[0], o.raw_spacing[1], o.raw_spacing[2]};
  }
  r.header_bytes = o.raw_header_bytes;
  return r;
}

// The volume options of data files opened directly; Error when --raw-* names no .raw input.
VolumeLoadOptions volume_load_options(const InputOptions& o) {
  const std::optional<RawVolumeOptions> raw = raw_options(o);
  bool has_raw = false;
  for (const auto& f : o.inputs) has_raw = has_raw || std::filesystem::path(f).extension() == ".raw" || std::filesystem::path(f).extension() == ".RAW";
  if (raw && !has_raw) throw Error("--raw-dims, --raw-type: no .raw file among the inputs");
  VolumeLoadOptions volume_options = o.choice;
  volume_options.raw = raw;
  if (!o.memory_budget.empty())  // in the document before its first read, so that nothing loads beyond it
    volume_options.memory_budget = with_context("--memory-budget", [&] { return parse_byte_size(o.memory_budget); });
  return volume_options;
}

// --memory-budget, checked, as the first of the sets (so that a --set memory_budget=... wins).
std::vector<std::string> sets_with_budget(const InputOptions& o, const std::vector<std::string>& extra_sets) {
  if (o.memory_budget.empty()) return extra_sets;
  with_context("--memory-budget", [&] { return parse_byte_size(o.memory_budget); });
  std::vector<std::string> sets{"memory_budget=" + nlohmann::json(o.memory_budget).dump()};
  sets.insert(sets.end(), extra_sets.begin(), extra_sets.end());
  return sets;
}

// `extra_sets` (after --memory-budget), then the user's --set, on a data files' document.
void apply_sets(nlohmann::json& doc, const InputOptions& o, const std::vector<std::string>& extra_sets) {
  const std::vector<std::string> first = sets_with_budget(o, extra_sets);
  with_context("--set", [&] {
    for (const auto& s : first) apply_override(doc, s);
    for (const auto& s : o.sets) apply_override(doc, s);
  });
}

}  // namespace

void add_input_options(CLI::App& cmd, InputOptions& o) {
  cmd.add_option("inputs", o.inputs,
                 "A scene file (.json, docs/scene-file.md), or data files that make a scene: volumes (.nrrd, .nhdr, .nii, .nii.gz, "
                 ".tif, .tiff, .vti, .vtk, .vdb, a folder of DICOM slices or .dcm files, .raw with --raw-dims and --raw-type) and molecules (.pdb, .ent, .cif, .mmcif, .gro, .xyz; each optionally .gz)")
      ->required();
  cmd.add_option("--set", o.sets, "Override a scene value by dotted path: key=value (value parsed as JSON if valid)");
  cmd.add_flag("--strict", o.strict, "Keys that the chosen techniques do not read are an error (exit 1, no image), not a note");
  cmd.add_option("--raw-dims", o.raw_dims, "Voxels along x y z of the .raw volumes")->expected(3)->check(CLI::Range(std::int64_t{1}, std::int64_t{1} << 20));
  cmd.add_option("--raw-type", o.raw_type, "Voxel type of the .raw volumes: uint8, int16, uint16, float32");
  cmd.add_option("--raw-spacing", o.raw_spacing, "Voxel spacing x y z of the .raw volumes (default 1 1 1)")->expected(3);
  cmd.add_option("--raw-endian", o.raw_endian, "Byte order of the .raw volumes: little (default) or big");
  cmd.add_option("--raw-header-bytes", o.raw_header_bytes, "Bytes to skip at the start of the .raw volumes");
  add_volume_choice_options(cmd, o.choice);
  cmd.add_option("--memory-budget", o.memory_budget,
                 "What the volumes may hold in memory (voxels, macrocells, stored gradients), e.g. 4G or 512M: an OME-Zarr pyramid "
                 "opens at the finest level that fits (the scene's memory_budget)");
}

void add_volume_choice_options(CLI::App& cmd, VolumeLoadOptions& choice) {
  cmd.add_option("--series", choice.series, "DICOM input holding several series: the one to open (SeriesInstanceUID, or its index in "
                                            "`penumbra info`; default: the series with the most slices)");
  cmd.add_option("--channel", choice.channel, "Multi-channel TIFF stacks, OME-Zarr images and HDF5 datasets (c z y x): the channel "
                                              "(from 0; default 0)")->check(CLI::Range(0, 1 << 20));
  cmd.add_option("--level", choice.level, "OME-Zarr pyramids: the level (0 the finest; default: the finest that fits a quarter of "
                                          "the memory)")->check(CLI::Range(0, 64));
  cmd.add_option("--dataset", choice.dataset, "HDF5 files: the dataset, its path in the file (default: the only dataset of three or more axes)");
  cmd.add_option("--grid", choice.grid, "OpenVDB files: the grid (its name, or its index in `penumbra info`; default: "
                                        "'density', else the first float grid)");
}

bool chooses_part(const VolumeLoadOptions& c) {
  return !c.series.empty() || c.channel >= 0 || c.level >= 0 || !c.dataset.empty() || !c.grid.empty();
}

std::optional<SceneDocument> scene_file_document(const InputOptions& o, const std::vector<std::string>& extra_sets) {
  if (o.inputs.size() != 1 || input_kind(o.inputs.front()) != InputKind::SceneFile) return std::nullopt;
  if (raw_options(o)) throw Error("--raw-dims, --raw-type: the layout of .raw volumes opened directly (a scene file gives 'raw' per volume)");
  if (chooses_part(o.choice))
    throw Error("--series, --channel, --level, --dataset, --grid: for volumes opened directly (a scene file gives 'series', 'channel', 'level', 'dataset' and "
                "'grid' per volume)");
  const std::string& path = o.inputs.front();
  SceneDocument d{read_json_file(path), std::filesystem::path(path).parent_path().string()};
  const std::vector<std::string> first = sets_with_budget(o, extra_sets);
  with_context(path, [&] {
    for (const auto& s : first) apply_override(d.document, s);
    for (const auto& s : o.sets) apply_override(d.document, s);
  });
  return d;
}

Engine open_inputs(const InputOptions& o, const std::vector<std::string>& extra_sets) {
  if (auto d = scene_file_document(o, extra_sets))
    return with_context(o.inputs.front(), [&] { return Engine(std::move(d->document), d->base_dir, SceneReadOptions{o.strict}); });
  SceneDataCache cache;
  nlohmann::json doc = data_scene(o.inputs, volume_load_options(o), cache);
  apply_sets(doc, o, extra_sets);
  return Engine(std::move(doc), "", SceneReadOptions{o.strict, &cache});
}

DataFilesDocument data_files_document(const InputOptions& o, const std::vector<std::string>& extra_sets) {
  DataFilesDocument d;
  d.document = data_scene_inputs(o.inputs, volume_load_options(o));
  d.complete = [o, extra_sets](nlohmann::json& doc, const Scene& read, const std::function<nlohmann::json(std::size_t)>& choose) {
    complete_data_scene(doc, read, choose);
    apply_sets(doc, o, extra_sets);
  };
  return d;
}

void check_scene_file_path(const std::string& path) {
  const std::filesystem::path p(path);
  if (p.extension() != ".json") throw Error("--write-scene " + path + ": expected a .json file name");
  const auto folder = p.parent_path();
  if (!folder.empty() && !std::filesystem::is_directory(folder)) throw Error("--write-scene " + path + ": directory '" + folder.string() + "' does not exist");
}

void write_scene_file(const Engine& engine, const std::string& path) {
  check_scene_file_path(path);
  const auto folder = std::filesystem::path(path).parent_path();
  const std::string text = engine.saved_document(folder.string()).dump(2) + "\n";
  with_context("--write-scene " + path, [&] { replace_file_contents(path, text); });
}

}  // namespace penumbra::cli
