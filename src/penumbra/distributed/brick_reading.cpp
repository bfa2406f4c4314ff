#include "penumbra/distributed/brick_reading.h"

#include <algorithm>
#include <functional>
#include <optional>
#include <utility>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/data/transfer_function_choice.h"
#include "penumbra/data/volume_stats.h"
#include "penumbra/distributed/sphere_split.h"
#include "penumbra/distributed/volume_slabs.h"
#include "penumbra/scene_io/scene_file.h"
#include "penumbra/registry/technique_catalog.h"
#include "penumbra/registry/registry.h"

namespace penumbra {
namespace {

// The slices slab `rank` owns (volume_slabs' split of the grid, without ghosts).
SliceRange own_slices(int whole_slices, int rank, int ranks) {
  if (ranks < 1 || ranks > whole_slices)
    throw Error(std::to_string(ranks) + " slabs for a volume of " + std::to_string(whole_slices) +
                " voxel slices along z (expected 1 to " + std::to_string(whole_slices) + ")");
  const auto first = [&](int r) { return static_cast<int>(static_cast<long long>(whole_slices) * r / ranks); };
  return {first(rank), first(rank + 1) - first(rank)};
}

using VolumeReader = std::function<Volume(const std::vector<std::string>&, const VolumeLoadOptions&)>;

}  // namespace

SliceRange brick_slices(int whole_slices, int rank, int ranks) {
  const SliceRange own = own_slices(whole_slices, rank, ranks);
  const int first = std::max(0, own.first - kGhostSlices), end = std::min(whole_slices, own.first + own.count + kGhostSlices);
  return {first, end - first};
}

std::string why_read_whole(const Scene& scene) {
  if (splits_spheres(scene)) return "the scene has no volume: every rank reads the particle files and keeps its share of the spheres";
  if (scene.volumes.size() != 1)
    return "the scene has " + std::to_string(scene.volumes.size()) + " volumes (bricks are read for one)";
  if (const auto ambient = make_ambient_technique(scene.ambient); ambient && ambient->reads_whole_volume())
    return "ambient occlusion (" + scene.ambient.technique + ") is built from the whole volume on every rank";
  for (const ShadowAssignment& a : shadow_assignments(scene))
    if ((a.casters & (kind_bit(ObjectKind::Volume) | kind_bit(ObjectKind::Isosurface))) && a.technique != "none" &&
        make_shadow_technique(a.technique, scene.shadows)->reads_whole_volume())
      return "the " + a.technique + " shadows are built from the whole volume on every rank (cssm, shadow_map, deep_shadow_map, "
             "sat_cone and light_pass are built per brick)";
  return "";
}

Scene build_distributed_scene(const nlohmann::json& document, const std::string& base_dir, bool strict, MpiWorld& world,
                              BrickReading& reading, const DocumentCompletion& complete) {
  const int ranks = world.size(), me = world.rank();
  reading = BrickReading{};
  // A reader of the chosen slices of every file volume, which notes what it read.
  int files_read = 0;
  const auto reader_of = [&](bool brick) -> VolumeReader {
    return [&, brick](const std::vector<std::string>& paths, const VolumeLoadOptions& options) {
      ++files_read;
      WindowRead read;
      Volume v = load_volume_window(paths, options, [&](const std::array<int, 3>& dims) {
        reading.whole_slices = dims[2];
        reading.slices = brick ? brick_slices(dims[2], me, ranks) : SliceRange{0, dims[2]};
        return reading.slices;
      }, read);
      reading.bytes_read += read.bytes_read;
      reading.cut_from_whole = reading.cut_from_whole || read.whole;
      return v;
    };
  };
  // The document to build the final scene from: with `complete`, completed from the scene first read.
  nlohmann::json completed = document;
  const auto completion = [&](const Scene& read, const std::function<nlohmann::json(std::size_t)>& choose) {
    if (complete) world.run_agreed([&] { complete(completed, read, choose); });
  };

  // 1. every rank reads its brick and builds its scene (nothing collective until all are through)
  std::optional<Scene> scene;
  SceneDataCache cache;
  const VolumeReader brick_reader = reader_of(true);
  world.run_agreed([&] {
    SceneReadOptions options{strict, &cache};
    options.volume_reader = &brick_reader;
    scene = build_scene(document, base_dir, options);
    check_splittable(*scene);
    reading.why = why_read_whole(*scene);
    if (reading.why.empty() && files_read != 1) reading.why = "the volume is not read from a file";
  });

  // 2. bricks only when every rank can: else the whole volume, read again where a brick was read
  const int mine[] = {reading.why.empty() ? 1 : 0};
  const std::vector<int> all = world.all_gather(mine);
  const bool bricks = std::all_of(all.begin(), all.end(), [](int ok) { return ok == 1; });
  // (`then_complete`: the document is not completed yet)
  const auto read_whole = [&](bool then_complete) {
    bool windowed = false;
    cache.for_each_volume([&](Volume& v) { windowed = windowed || v.is_window(); });
    SceneDataCache whole_cache;
    if (windowed) {
      reading.bytes_read = 0;
      reading.cut_from_whole = false;
      const VolumeReader whole_reader = reader_of(false);
      world.run_agreed([&] {
        SceneReadOptions options{strict, &whole_cache};
        options.volume_reader = &whole_reader;
        scene = build_scene(then_complete ? document : completed, base_dir, options);
      });
    }
    SceneDataCache& read = windowed ? whole_cache : cache;
    if (complete && then_complete) {
      const Scene first = std::move(*scene);
      completion(first, [&](std::size_t i) { return choose_transfer_function(*first.volumes[i].volume); });
      world.run_agreed([&] { scene = build_scene(completed, base_dir, SceneReadOptions{strict, &read}); });
    }
    if (scene->volumes.empty()) return std::move(*scene);  // spheres, split by space once read (sphere_split.h)
    const Volume& volume = *scene->volumes.front().volume;
    if (reading.whole_slices == 0) reading.whole_slices = volume.dims()[2];  // not read from a file
    reading.slices = {0, reading.whole_slices};
    reading.volume_bytes = volume.memory_bytes();
    return std::move(*scene);
  };
  if (!bricks) {
    if (reading.why.empty()) reading.why = "another rank's scene cannot be read as bricks";
    return read_whole(true);
  }

  // 3. what no rank knows alone: the whole grid's value range, then its histogram (each rank counts the
  // slices it owns), for the transfer function chosen from the data
  Volume* volume = nullptr;
  cache.for_each_volume([&](Volume& v) { volume = &v; });
  float range[] = {volume->min_value(), -volume->max_value()};
  world.minimum(range);
  const float lo = range[0], hi = -range[1];
  VolumeHistogram histogram;
  world.run_agreed([&] {
    volume->set_value_range(lo, hi);
    const SliceRange own = own_slices(reading.whole_slices, me, ranks);
    const int from = own.first - volume->window_first();
    histogram = compute_histogram_part(*volume, kTransferChoiceBins, lo, hi, from, from + own.count);
  });
  world.sum(histogram.counts);
  cache.set_transfer_function_chooser([histogram](const Volume& v) { return choose_transfer_function(histogram, v.type()); });
  completion(*scene, [&](std::size_t) { return choose_transfer_function(histogram, volume->type()); });

  // 4. the scene again, from the voxels already read, with what the ranks found (and completed); the
  // completion may have asked for what reads the whole volume
  world.run_agreed([&] {
    scene = build_scene(completed, base_dir, SceneReadOptions{strict, &cache});
    reading.why = why_read_whole(*scene);
  });
  const int completed_ok[] = {reading.why.empty() ? 1 : 0};
  if (const std::vector<int> agreed = world.all_gather(completed_ok); !std::all_of(agreed.begin(), agreed.end(), [](int ok) { return ok == 1; })) {
    if (reading.why.empty()) reading.why = "another rank's scene cannot be read as bricks";
    return read_whole(false);
  }
  reading.bricked = true;
  reading.volume_bytes = volume->memory_bytes();
  return std::move(*scene);
}

}  // namespace penumbra
