// Each rank of a distributed frame reads only its brick of the volume (issue 20; what makes a volume
// larger than one node's memory renderable): slab r's voxel slices (distributed/volume_slabs.h) and
// kGhostSlices more on each side, which is all that its samples reach — a sample it owns lies within half
// a slice of its slices, its trilinear cell one slice further, and the central-difference gradients at
// that cell's corners one more. Raw files and NRRD raw data are read by seeking; NRRD gzip data is
// decompressed up to the brick's last slice (the slices before it dropped as they stream by); every
// other format is read whole and cut (data/io/volume_io.h load_volume_window).
//
// What one rank cannot know alone is then found across the ranks, so that every rank's scene is the
// same as the whole volume's: the value range (a minimum over the ranks), which the transfer function
// and the gradient weights read, and, for a volume without a transfer function, the histogram that
// chooses one (each rank counts its own slices, without the ghosts; the counts are summed). The window
// keeps the whole grid's box (Volume::bounds), so camera, light frustums and ray lattices are the whole
// volume's. The frame is then the one where every rank holds the whole volume, bit for bit.
//
// A scene is read as bricks when its one volume comes from a file and no light structure reads the
// whole volume (ShadowTechnique/AmbientTechnique::reads_whole_volume: the CSSM, classic and deep shadow
// maps and the isosurface light pass combine over bricks, the SAT's cone shadows and ambient occlusion
// read the SAT, which is summed over the bricks); an isosurface of it is then extracted by each rank
// from its brick's cells. Otherwise (ray-traced shadows or ambient occlusion) every rank reads the
// whole volume, and the statistics say why.
//
// | parameter     | meaning                                                                  |
// | kGhostSlices  | voxel slices read beyond a slab's own on each side (2)                   |
#pragma once

#include <cstdint>
#include <functional>
#include <string>

#include <nlohmann/json.hpp>

#include "penumbra/data/io/volume_io.h"
#include "penumbra/distributed/mpi_world.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

constexpr int kGhostSlices = 2;

// Slab `rank` of `ranks`'s voxel slices with kGhostSlices more on each side, within the grid. Error when
// there are more ranks than slices.
SliceRange brick_slices(int whole_slices, int rank, int ranks);

// "" when the scene's volume can be read as bricks, else why not (see the top of this file).
std::string why_read_whole(const Scene& scene);

// What this rank read.
struct BrickReading {
  bool bricked = false;        // this rank read its brick only (else the whole volume; `why` says why)
  std::string why;
  SliceRange slices;           // the voxel slices it holds (the whole grid's when not bricked)
  int whole_slices = 0;
  std::uint64_t bytes_read = 0;
  bool cut_from_whole = false;  // the format could not seek: the file was read whole and cut
  std::size_t volume_bytes = 0;  // the voxels it holds
};

// Completes a document from the scene it loaded (data files opened directly: scene_io/data_scene.h
// complete_data_scene, then the command's overrides); `choose(i)` gives volume i's transfer function
// chosen from the whole grid's histogram.
using DocumentCompletion =
    std::function<void(nlohmann::json& document, const Scene& read, const std::function<nlohmann::json(std::size_t)>& choose)>;

// The scene of `document` (relative paths against base_dir) on every rank, its volume read as bricks
// when it can be, and completed across the ranks (above). With `complete`, the scene is built from the
// document it completes (bricks are read when the completed scene allows them; a brick read is not
// read again). Collective: every rank calls it; an error on any rank throws the same Error on all of them.
Scene build_distributed_scene(const nlohmann::json& document, const std::string& base_dir, bool strict, MpiWorld& world,
                              BrickReading& reading, const DocumentCompletion& complete = {});

}  // namespace penumbra
