// View-dependent refinement of a volume larger than memory (issue 43; paper 002's "interactive
// exploration of large scale datasets on commodity hardware").
//
// A volume the scene reader opened from an OME-Zarr pyramid at a level coarser than its finest, or from a
// file without levels read reduced (VolumeObject::pyramid: memory allowed no finer grid for the whole
// volume; a file's levels are its reductions by powers of two, data/io/volume_reduction.h) is drawn, in full-quality
// frames, from a box of a finer level that covers what the camera sees of it: the bounds of the
// frustum ∩ the volume's box up to the depth where the opened level's voxel is as small as a pixel,
// with an apron of two voxels for interpolation and central differences. The level is the finest whose
// box fits what the volumes leave of the budget (Scene::refinement_bytes), and no finer than needed:
// the first whose voxel is no larger than a pixel at the depth of the part's centre. Where the finer
// level's box of the whole part does not fit (a deep view along a long volume), the near part that fits
// is refined and the ray caster draws the rest from the opened level on the same lattice (one visible
// volume; beside others the box replaces the volume and must hold all it shows). Previews keep the opened level (they must come at once).
// A full frame's light structures that march the volume (shadow maps, the deep shadow map, the CSSM,
// ray-traced shadows and ambient occlusion) cast from the box where it lies and from the opened level
// elsewhere (ShadowCasters' CastingVolume::finer), on a lattice as fine as the box's voxel; what reads
// the extinction SAT (cone shadows, volume ambient occlusion, the light cache) keeps the opened level.
// An isosurface (`points`, `raycast`) is drawn, in full frames, from the box where it lies and from the
// opened level around it, in the eye pass, the light pass and exact shadow rays (CastingIsosurface::finer); the
// box is the visible volume's, or, for a hidden volume, one of its own, which lends or moves as below.
// The box is kept while the view stays inside it (a camera move inside a zoomed region reads nothing);
// a view outside it reads a new box — taking from the old one the chunks both hold when the two fit the
// budget together; else the old box moves: its memory becomes the new box's (grown or shrunk, its pages
// remapped, not copied: VoxelBytes), the voxels both hold moved in place, and only what it did not hold is read — and
// FrameResult::refinement says what was held, loaded, read from disk, reused and evicted.
//
// | what                     | where                    | meaning                                          |
// |--------------------------|--------------------------|--------------------------------------------------|
// | volumes[].refine         | scene file (default true) | false: full frames draw the opened level        |
// | memory_budget            | scene file / --memory-budget | what it leaves after the volumes bounds the box |
// | kRefinementApron = 2     | here                     | voxels of the finer level around the seen part   |
// | kRefinementMargin = 1/8  | here                     | of the seen part's extent, added on each side    |
//                                                         where it fits: a small move stays inside the box
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "penumbra/data/io/volume_io.h"
#include "penumbra/render/prepared_volume.h"
#include "penumbra/scene/scene.h"

namespace penumbra {

constexpr int kRefinementApron = 2;
constexpr float kRefinementMargin = 0.125f;

// The world box of what `camera` sees of `box` no deeper than `far` (along the view direction): the
// bounds of frustum ∩ box, exact — the vertices of the intersection of the two convex bodies: the eye
// when it lies in the box, the box's corners inside the frustum, the frustum's edges through the box's
// faces and the box's edges through the frustum's sides and far plane. Empty when none of it is seen.
Box3 visible_part(const Camera& camera, const Box3& box, float far = kInfinity);

// A box of one level of a pyramid: voxels [lo, hi) along x, y, z of that level.
struct LevelBox {
  int level = 0;
  std::array<std::int64_t, 3> lo{}, hi{};
  std::array<int, 3> dims() const {
    return {static_cast<int>(hi[0] - lo[0]), static_cast<int>(hi[1] - lo[1]), static_cast<int>(hi[2] - lo[2])};
  }
  bool contains(const LevelBox& b) const;  // same level, b inside
};
bool overlaps(const LevelBox& a, const LevelBox& b);  // same level, sharing voxels

// The voxels of `level` whose cells reach into `world`, with the apron, within the level.
LevelBox level_box(const PyramidSource& pyramid, int level, const Box3& world);
// What a box holds: voxels and macrocells, and stored gradients when `gradients`.
std::uint64_t refined_bytes(const LevelBox& box, ScalarType type, bool gradients);

// The box a full frame draws `pyramid` (its world box `volume_box`) from for `camera`: the part of the
// volume in view up to the depth where the opened level's voxel is as small as a pixel, from the finest
// level finer than the opened one whose box of it fits `bytes` (with stored gradients when `gradients`
// and they fit, else without), stopping at the first level whose voxel is no larger than a pixel at the
// part's centre. Where a level's box of the whole part does not fit, `cut_depth` takes the nearest part
// that does (at least a quarter of its depth; the ray caster draws the rest from the opened level).
// nullopt when the opened level is fine enough, nothing is in view or no finer box fits.
struct RefinementChoice {
  LevelBox box;
  bool stored_gradients = false;
  Box3 seen;  // the world part the box covers (before its margin)
};
std::optional<RefinementChoice> choose_refinement(const Camera& camera, const PyramidSource& pyramid, const Box3& volume_box,
                                                  std::uint64_t bytes, bool gradients, bool cut_depth);

// What one full frame's refinement of one volume did (FrameResult::refinement, `--stats`).
struct RefinementStats {
  std::size_t volume = 0;  // the scene's volumes[] index
  int opened_level = 0, level = 0;
  std::array<int, 3> dims{};
  std::uint64_t held_bytes = 0;     // what the refined box holds (voxels, macrocells, gradients)
  std::uint64_t loaded_bytes = 0;   // brought into memory this frame (0: the box held was kept)
  std::uint64_t read_bytes = 0;     // read from the files for them (compressed)
  std::uint64_t reused_bytes = 0;   // of their voxels, copied from the box held before (it overlapped)
  std::uint64_t evicted_bytes = 0;  // boxes given up this frame
  std::uint64_t kept_bytes = 0;     // boxes drawn before, kept in memory for views that come back
  double load_ms = 0;               // reading and preparing the box
  std::string error;  // the box the view needs could not be read (why: the chunk and the fault); the
                      // frame draws the opened level there, and views inside that box do not try again
};

// A box whose read failed: views whose part lies inside it draw the opened level and report `error`
// without reading again (a corrupt chunk does not mend itself; another store, level or part is tried).
struct FailedRefinement {
  LevelBox box;
  std::string key;  // PyramidSource::key
  std::string error;
  bool covers(const PyramidSource& pyramid, const RefinementChoice& choice) const;
};

// Whether a box held (`held`, holding `held_bytes`) serves a view that chose `choice`: it covers the part
// wanted at its own level, is at least as fine, and still fits `left`.
bool box_serves(const LevelBox& held, std::uint64_t held_bytes, const PyramidSource& pyramid, const std::optional<RefinementChoice>& choice,
                std::uint64_t left);

// Reads the box `choice` names by `read` (which fills the WindowRead and returns the bytes it then holds),
// recording the bytes and the time in `stats` and clearing `failed`; a read that fails (a chunk cut short,
// corrupt, unreadable) leaves `failed` naming the box and the fault, in `stats.error` too, and returns false.
bool read_refinement_box(const RefinementChoice& choice, const std::string& key, const std::function<std::uint64_t(WindowRead&)>& read,
                         RefinementStats& stats, std::optional<FailedRefinement>& failed);

// Each refined volume of a frame as `--stats`, the Python stats and the viewer's frame message list it:
// [{"volume", "opened_level", "level", "dims", "held_bytes", "loaded_bytes", "read_bytes",
//   "reused_bytes", "evicted_bytes", "kept_bytes", "load_ms"[, "error"]}, ...] ("error" only where a read failed).
nlohmann::json refinement_json(const std::vector<RefinementStats>& refinement);

// A refined box of one volume, prepared for the eye pass like the volume itself.
class RefinedVolume {
public:
  // Reads `choice` from `coarse.pyramid`; its value range is the union of the box's and the opened
  // level's (the transfer function's table and the shading weights see the range they saw before).
  // Its lattice step is the object's step in the box's voxels (the renderer then shares the finest).
  // `previous`: a box of the same level and store held until now, whose voxels the new box takes where
  // they overlap instead of reading their chunks. `moving`: such a box given up for this one (the budget
  // holds one of them): when nothing else shares its voxels, its storage becomes this box's, the voxels both hold moved in place (HeldBox::storage), else it lends them as
  // `previous` does; it is gone after.
  RefinedVolume(const VolumeObject& coarse, const RefinementChoice& choice, WindowRead* read, const RefinedVolume* previous = nullptr,
                std::unique_ptr<RefinedVolume> moving = nullptr);

  // Follows the coarse object's edits (transfer function, compositing, step, jitter, flags); true when
  // the table and the empty cells must be built again (a transfer function or compositing changed).
  bool follow(const VolumeObject& coarse);
  const LevelBox& box() const { return box_; }
  // Whether the box was read from this pyramid's store and channel (a volume's file edited to another
  // store of the same grid must not keep the old store's box).
  bool reads(const PyramidSource& pyramid) const { return pyramid.key == key_; }
  std::uint64_t held_bytes() const;  // refined_bytes of its box: what the budget counts
  PreparedVolume& prepared() { return *prepared_; }
  const VolumeObject& object() const { return object_; }  // the coarse object with the box as its volume
  float step_world() const { return object_.step_world(); }  // its own lattice step

private:
  LevelBox box_;
  std::string key_;  // the source it was read from (PyramidSource::key)
  std::shared_ptr<Volume> voxels_;  // the box's voxels, which a box that moves takes over
  VolumeObject object_;  // the coarse object with voxels_ as its volume
  std::unique_ptr<PreparedVolume> prepared_;
};

}  // namespace penumbra
