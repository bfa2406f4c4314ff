// A scene for data files opened directly (`penumbra render chest_ct.nrrd`, `penumbra view 1aon.pdb.gz`):
// what a user of ParaView or VMD gets on opening a file, with penumbra's shadows.
//
// | in the scene           | chosen                                                                    |
// |------------------------|---------------------------------------------------------------------------|
// | each volume file       | a transfer function from its data (data/transfer_function_choice.h)       |
// | each molecule file     | PDB / mmCIF coloured by chain, GRO / XYZ by element                       |
// | up axis                | z for a CT in Hounsfield units (the patient's long axis), else y          |
// | camera                 | framing everything (the scene reader's default), from the front and above |
// | light                  | one directional light from above, over the viewer's shoulder              |
// | floor                  | a light-grey plane under the data that receives its shadows (casts none)  |
// | shadows                | volumes cssm, spheres issm (paper 003)                                    |
// | ambient                | particle AO when there are spheres                                        |
// | background             | white for molecules alone (Mol*, 1aon.json), else dark grey               |
//
// Several files make one mixed scene. File paths in the document are absolute.
#pragma once

#include <nlohmann/json.hpp>

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "penumbra/data/io/volume_io.h"
#include "penumbra/scene_io/scene_file.h"

namespace penumbra {

enum class InputKind { SceneFile, Volume, Particles };

// What a path names, by its extension (after an optional .gz): Error naming the file and the known
// extensions otherwise.
InputKind input_kind(const std::string& path);

// The scene document for the data files (see above). DICOM slices given one by one (.dcm) make one
// volume; a folder is a DICOM series. `volume_options` reads the volumes: `raw` the .raw files,
// `series` the DICOM inputs, `channel` the TIFF stacks. The data is loaded into `cache` (to choose
// transfer functions and place the floor), so that an engine given the same cache does not load it
// again. Errors name the file.
nlohmann::json data_scene(const std::vector<std::string>& files, const VolumeLoadOptions& volume_options, SceneDataCache& cache);

// data_scene in two steps, for a reader that loads the data its own way (a rank of a distributed frame
// reads its brick, distributed/brick_reading.h): the document of the files as they are (each volume
// invisible, without a transfer function; nothing is loaded; Errors name the file), then, from the
// scene that document loaded, the rest of the table above, `choose(i)` giving volume i's transfer
// function.
nlohmann::json data_scene_inputs(const std::vector<std::string>& files, const VolumeLoadOptions& volume_options);
void complete_data_scene(nlohmann::json& doc, const Scene& loaded, const std::function<nlohmann::json(std::size_t volume)>& choose);

}  // namespace penumbra
