#include "penumbra/scene_io/data_scene.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <limits>
#include <filesystem>
#include <functional>
#include <string_view>

#include "penumbra/core/error.h"
#include "penumbra/data/io/particle_io.h"
#include "penumbra/data/transfer_function.h"
#include "penumbra/data/transfer_function_choice.h"
#include "penumbra/data/volume_stats.h"

namespace penumbra {
namespace {

bool has_extension(const std::string& path, std::string_view ext) {
  if (path.size() < ext.size()) return false;
  for (std::size_t i = 0; i < ext.size(); ++i)
    if (std::tolower(static_cast<unsigned char>(path[path.size() - ext.size() + i])) != ext[i]) return false;
  return true;
}

nlohmann::json vec3(const Vec3& v) { return nlohmann::json::array({v.x, v.y, v.z}); }

nlohmann::json raw_json(const RawVolumeOptions& o) {
  return {{"dims", {o.dims[0], o.dims[1], o.dims[2]}},
          {"type", to_string(o.type)},
          {"endian", o.big_endian ? "big" : "little"},
          {"spacing", vec3(o.spacing)},
          {"header_bytes", o.header_bytes}};
}

// A volume whose file places it in a patient frame (NIfTI, a DICOM series: LPS, superior along +z).
// How far back from the box's centre, along `direction`, a camera looking at that centre must stand
// for the box's eight corners to fit a view of `fov_deg` (vertical) and `aspect`, with a 5% margin.
// A flat or long box (a CT series: 550 x 550 x 150 mm) fits much closer than its bounding sphere,
// which is what the scene file's framing fits and which left such data a third of the view.
constexpr float kShownAlpha = 0.01f;   // a transfer function's opacity below this is taken as transparent
constexpr double kFramingTrim = 0.005;  // share of the shown voxels left out of the framed box at each end

// The value of the last point below the transfer function's first point of opacity > kShownAlpha: the
// voxels at or below it are transparent (the lowest value when the first point already shows).
float shown_threshold(const TransferFunction& tf) {
  float threshold = -std::numeric_limits<float>::infinity();
  for (const TransferPoint& p : tf.points()) {
    if (p.alpha > kShownAlpha) break;
    threshold = p.value;
  }
  return threshold;
}

float box_fit_distance(const Box3& box, const Vec3& direction, const Vec3& up, float fov_deg, float aspect) {
  const Frame f = Frame::from_w(direction, up);
  const float tan_half = std::tan(radians(fov_deg) * 0.5f);
  const Vec3 centre = box.center();
  float distance = 0;
  for (int k = 0; k < 8; ++k) {
    const Vec3 corner{(k & 1) ? box.hi.x : box.lo.x, (k & 2) ? box.hi.y : box.lo.y, (k & 4) ? box.hi.z : box.lo.z};
    const Vec3 c = f.to_local(corner - centre);  // x right, y up, z towards the eye
    distance = std::max({distance, c.z + std::abs(c.x) / (tan_half * aspect), c.z + std::abs(c.y) / tan_half});
  }
  return 1.05f * distance;
}

// A folder of DICOM slices: any folder but a Zarr store.
bool is_dicom_folder(const std::string& path) {
  std::error_code ec;
  return std::filesystem::is_directory(path, ec) && !is_zarr_store(path);
}

bool in_patient_frame(const nlohmann::json& file) {
  if (file.is_array()) return true;  // DICOM slices
  const std::string path = file.get<std::string>();
  return has_extension(path, ".nii") || has_extension(path, ".nii.gz") || has_extension(path, ".dcm") ||
         has_extension(path, ".dicom") || is_dicom_folder(path);
}

}  // namespace

InputKind input_kind(const std::string& path) {
  if (has_extension(path, ".json")) return InputKind::SceneFile;
  if (is_volume_file(path)) return InputKind::Volume;
  if (!particle_file_format(path).empty()) return InputKind::Particles;
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw Error(path + ": no such file or folder");
  throw Error(path + ": unknown kind of file (expected a scene .json; a volume .nrrd, .nhdr, .nii, .nii.gz, .raw, .tif, .tiff, "
                     ".vti, .vtk, .h5, .hdf5, .dcm, a folder of DICOM slices or a Zarr store; or a molecule .pdb, .ent, .cif, .mmcif, .gro or .xyz, "
                     "each of those optionally .gz)");
}

nlohmann::json data_scene_inputs(const std::vector<std::string>& files, const VolumeLoadOptions& volume_options) {
  if (files.empty()) throw Error("no data files");
  nlohmann::json doc = nlohmann::json::object();
  doc["volumes"] = nlohmann::json::array();
  doc["particles"] = nlohmann::json::array();
  if (volume_options.memory_budget > 0) doc["memory_budget"] = volume_options.memory_budget;
  nlohmann::json dicom_slices = nlohmann::json::array();  // .dcm files given one by one: one volume
  bool has_dicom = false, has_tiff = false, has_vdb = false, has_zarr = false, has_hdf5 = false;
  for (const std::string& file : files) {
    const std::string path = std::filesystem::absolute(file).lexically_normal().string();
    switch (input_kind(file)) {
      case InputKind::SceneFile:
        throw Error(file + ": a scene file is opened on its own, not together with data files");
      case InputKind::Volume: {
        std::error_code ec;
        const bool folder = std::filesystem::is_directory(path, ec);
        if (!folder && (has_extension(path, ".dcm") || has_extension(path, ".dicom"))) {
          if (dicom_slices.empty()) doc["volumes"].push_back({{"file", dicom_slices}});  // filled below
          dicom_slices.push_back(path);
          has_dicom = true;
          break;
        }
        nlohmann::json v = {{"file", path}, {"visible", false}};  // visible once its transfer function is chosen
        if (has_extension(path, ".raw")) {
          if (!volume_options.raw)
            throw Error(file + ": a .raw file needs its layout: --raw-dims X Y Z and --raw-type (uint8, int16, uint16, float32)");
          v["raw"] = raw_json(*volume_options.raw);
        }
        const bool zarr = folder && is_zarr_store(path);
        if (folder && !zarr) {
          has_dicom = true;
          if (!volume_options.series.empty()) v["series"] = volume_options.series;
        }
        if (zarr) {
          has_tiff = true;  // a channel applies to it as to a TIFF stack
          has_zarr = true;
          if (volume_options.channel >= 0) v["channel"] = volume_options.channel;
          if (volume_options.level >= 0) v["level"] = volume_options.level;
        }
        if (has_extension(path, ".tif") || has_extension(path, ".tiff")) {
          has_tiff = true;
          if (volume_options.channel >= 0) v["channel"] = volume_options.channel;
        }
        if (is_hdf5_path(path)) {
          has_tiff = has_hdf5 = true;  // a channel applies to it as to a TIFF stack
          if (volume_options.channel >= 0) v["channel"] = volume_options.channel;
          if (!volume_options.dataset.empty()) v["dataset"] = volume_options.dataset;
        }
        if (has_extension(path, ".vdb")) {
          has_vdb = true;
          if (!volume_options.grid.empty()) v["grid"] = volume_options.grid;
        }
        doc["volumes"].push_back(v);
        break;
      }
      case InputKind::Particles: {
        const std::string format = particle_file_format(path);
        doc["particles"].push_back({{"file", path}, {"color_by", format == "pdb" || format == "mmcif" ? "chain" : "element"}});
        break;
      }
    }
  }
  for (auto& v : doc["volumes"])
    if (v["file"].is_array()) {  // the DICOM slices, in the order given (the reader sorts them)
      v["file"] = dicom_slices;
      v["visible"] = false;
      if (!volume_options.series.empty()) v["series"] = volume_options.series;
    }
  if (!volume_options.series.empty() && !has_dicom) throw Error("--series: no DICOM series (a folder or .dcm files) among the inputs");
  if (volume_options.channel >= 0 && !has_tiff) throw Error("--channel: no TIFF stack (.tif, .tiff), OME-Zarr image or HDF5 file among the inputs");
  if (volume_options.level >= 0 && !has_zarr) throw Error("--level: no OME-Zarr pyramid (a Zarr store's folder) among the inputs");
  if (!volume_options.dataset.empty() && !has_hdf5) throw Error("--dataset: no HDF5 file (.h5, .hdf5) among the inputs");
  if (!volume_options.grid.empty() && !has_vdb) throw Error("--grid: no OpenVDB file (.vdb) among the inputs");
  return doc;
}

void complete_data_scene(nlohmann::json& doc, const Scene& loaded, const std::function<nlohmann::json(std::size_t)>& choose) {
  bool patient = false;  // z up: a CT in Hounsfield units or a volume in a patient frame
  for (std::size_t i = 0; i < loaded.volumes.size(); ++i) {
    auto& v = doc["volumes"][i];
    v["transfer_function"] = choose(i);
    if (loaded.volumes[i].volume->level_set()) {  // a level set is its surface: the isosurface at 0
      doc["isosurfaces"].push_back({{"volume", i}, {"value", 0.0}});
      continue;
    }
    v.erase("visible");
    patient = patient || v["transfer_function"].value("preset", "") == "ct-bone" || in_patient_frame(v["file"]);
  }
  const bool molecules_only = loaded.volumes.empty();
  if (doc["volumes"].empty()) doc.erase("volumes");
  if (doc["particles"].empty()) doc.erase("particles");

  const Vec3 up = patient ? Vec3{0, 0, 1} : Vec3{0, 1, 0};
  Box3 box;  // of the data (the volumes are not visible yet, so not casters)
  for (const auto& v : loaded.volumes) box.extend(v.volume->bounds());
  for (const auto& p : loaded.particles) box.extend(p.set->bounds());
  const Vec3 size = box.hi - box.lo;
  const float diagonal = length(size);
  const Vec3 centre = box.center();
  const float below = 0.5f * dot(size, up) + 0.04f * diagonal;  // the floor just under the data
  doc["planes"] = nlohmann::json::array({{{"point", vec3(centre - up * below)},
                                          {"normal", vec3(up)},
                                          {"color", {0.8, 0.8, 0.8}},
                                          {"size", 4.0f * diagonal},
                                          {"casts_shadows", false}}});  // below everything: it only receives
  if (loaded.volumes.empty()) doc["shadows"] = {{"technique", "issm"}};
  else if (loaded.particles.empty()) doc["shadows"] = {{"technique", "cssm"}};
  else doc["shadows"] = {{"technique", "cssm"}, {"spheres", "issm"}};
  if (patient) {  // z up: the camera looks from the front (-y: anterior in LPS, every volume's world frame) and above
    doc["camera"] = {{"direction", {0.35, -1.0, 0.45}}, {"up", {0, 0, 1}}};
    doc["lights"] = nlohmann::json::array({{{"type", "directional"}, {"direction", {-0.4, 0.5, -1.0}}}});
  } else {
    doc["camera"] = {{"direction", {0.45, 0.4, 1.0}}};
    doc["lights"] = nlohmann::json::array({{{"type", "directional"}, {"direction", {-0.4, -1.0, -0.45}}}});
  }
  // Framed by the box's corners (box_fit_distance), not the bounding sphere, at the default view,
  // looking at that box's centre. A DICOM series is framed to what its transfer function shows
  // (shown_box: a CT's field of view is mostly air and couch, which left the body a third of the view);
  // every rank of a distributed render reads a series whole, so all of them frame it alike. Other
  // volumes, which a distributed render reads as bricks, are framed by their whole grid's box.
  Box3 shown;
  for (std::size_t i = 0; i < loaded.volumes.size(); ++i) {
    const Volume& v = *loaded.volumes[i].volume;
    const nlohmann::json& file = doc["volumes"][i]["file"];
    const bool series = (file.is_array() || (file.is_string() && is_dicom_folder(file.get<std::string>()))) &&
                        !v.level_set() && !v.is_window();
    const Box3 b = series ? box_above(v, shown_threshold(parse_transfer_function(doc["volumes"][i]["transfer_function"],
                                                                                 v.min_value(), v.max_value(), "")),
                                      kFramingTrim)
                          : Box3{};
    shown.extend(b.empty() ? v.bounds() : b);
  }
  for (const auto& p : loaded.particles) shown.extend(p.set->bounds());
  if (!shown.empty() && length(shown.hi - shown.lo) > 0) {
    const Camera camera;
    const auto& d = doc["camera"]["direction"];
    doc["camera"]["target"] = vec3(shown.center());
    doc["camera"]["distance"] = box_fit_distance(shown, Vec3{d[0].get<float>(), d[1].get<float>(), d[2].get<float>()}, up, camera.fov_deg,
                                                 static_cast<float>(camera.width) / static_cast<float>(camera.height));
  }
  if (loaded.particles.empty()) {
    doc["background"] = {0.08, 0.08, 0.1};
  } else {
    doc["ambient"] = {{"technique", "particle_ao"}, {"directions", 16}};
    doc["background"] = molecules_only ? nlohmann::json{1, 1, 1} : nlohmann::json{0.08, 0.08, 0.1};
  }
}

nlohmann::json data_scene(const std::vector<std::string>& files, const VolumeLoadOptions& volume_options, SceneDataCache& cache) {
  nlohmann::json doc = data_scene_inputs(files, volume_options);
  // read once as it stands (loading the data into the cache) to choose from what was loaded
  const Scene loaded = build_scene(doc, "", SceneReadOptions{false, &cache});
  complete_data_scene(doc, loaded, [&](std::size_t i) { return choose_transfer_function(*loaded.volumes[i].volume); });
  return doc;
}

}  // namespace penumbra
