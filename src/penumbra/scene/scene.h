// The scene a frame is rendered from: camera, volumes with their transfer functions, opaque planes,
// lights, and the shadow and ambient settings (docs/scene-file.md lists every key).
#pragma once

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "penumbra/core/clip_planes.h"
#include "penumbra/core/color.h"
#include "penumbra/core/math.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/particles.h"
#include "penumbra/data/transfer_function.h"
#include "penumbra/data/volume.h"
#include "penumbra/scene/technique_params.h"
#include "penumbra/scene/camera.h"
#include "penumbra/scene/light.h"

namespace penumbra {

// The kinds of object a scene holds. Every kind casts shadows on and receives them from every other
// (each object can opt out with casts_shadows / receives_shadows); a technique declares which kinds of
// caster it takes (technique_catalog.h).
enum class ObjectKind { Volume, Spheres, Isosurface, Plane };
constexpr int kObjectKinds = 4;
using KindMask = unsigned;
constexpr KindMask kind_bit(ObjectKind k) { return 1u << static_cast<unsigned>(k); }
constexpr KindMask kAllKinds = (1u << kObjectKinds) - 1;
std::string to_string(ObjectKind kind);          // "volumes", "spheres", "isosurfaces", "planes"
ObjectKind object_kind_from_string(const std::string& name);  // Error listing the names

// Whether an object darkens others and is darkened by them (ChimeraX-style per-object shadow control),
// and whether the scene's clip planes cut it (for the eye and every light alike).
struct ShadowFlags {
  bool casts_shadows = true;
  bool receives_shadows = true;
  bool clip = true;  // spheres are cut exactly (a cap on each cut face), isosurfaces end open at a cut
};

// volumes[].gradients = auto stores the gradients up to this size (1 GiB: a 640³ volume), and computes
// them per sample beyond it, where 4 bytes a voxel would add to a volume that is itself large (or
// where they would not fit the scene's memory_budget: the scene reader then chooses for auto).
constexpr std::size_t kStoredGradientBytes = std::size_t{1} << 30;

// A volume the scene reader opened coarser than its data, because memory allowed no finer grid for the
// whole volume — an OME-Zarr pyramid's coarser level, or a file without levels read reduced
// (data/io/volume_reduction.h) — and the levels a full frame reads the visible part of it from
// (render/view_refinement.h).
struct PyramidSource {
  struct Level {
    std::array<int, 3> dims{};       // voxels along x, y, z
    Vec3 spacing{1, 1, 1}, origin{0, 0, 0};  // of the voxel centres, as the level is placed when read
  };
  std::string path;                  // the store's folder or the file, for messages
  std::string key;                   // the file and what reads it (channel, dataset, series, layout): a box read
                                     // from one source is never taken for another's
  int opened = 0;                    // the level the volume holds
  std::vector<Level> levels;         // 0 the finest
  ScalarType type = ScalarType::UInt8;
  // Reads voxels [lo, hi) of a level, placed where they lie (origin: the box's first voxel), its value
  // range its own, opacities referring to the finest level's voxel; `held` a box of the same level in
  // memory whose voxels it may take instead of reading them (data/io/volume_io.h). Error naming what
  // could not be read.
  std::function<Volume(int level, const std::array<std::int64_t, 3>& lo, const std::array<std::int64_t, 3>& hi, WindowRead* read,
                       const HeldBox* held)>
      read_box;

  // The world box of the pyramid: its opened level's (`held`, the volume the scene holds) and its
  // finest's together (a coarser level's voxel centres reach half a voxel further than the finest's).
  Box3 bounds(const Volume& held) const;
};

struct VolumeObject : ShadowFlags {
  std::shared_ptr<const Volume> volume;
  std::string source;                   // file path or "procedural:<name>", for messages and stats
  TransferFunction transfer_function;
  bool has_shadow_transfer_function = false;
  TransferFunction shadow_transfer_function;  // used only for the shadow pass (CSSM paper §4)
  float step = 0.5f;                    // sampling step in voxels (of the smallest spacing)
  Compositing compositing = Compositing::Alpha;  // how the transfer function's opacity is read
  bool visible = true;
  bool jitter = true;                   // per-pixel offset of the sample lattice (against wood-grain rings)
  // volumes[].gradients: the shading normals stored (4 bytes a voxel), computed per sample from the
  // voxels (no memory, slower shading; the same frame), or (Auto) stored up to kStoredGradientBytes.
  enum class Gradients { Auto, Stored, OnTheFly } gradients = Gradients::Auto;
  std::size_t frames = 0;               // volumes[].files: the steps of the series (`volume` is step Scene::time); 0: one volume
  // volumes[].refine (default true): set when `volume` is a pyramid's level coarser than its finest or a
  // file read reduced; full frames then draw the part in view from a finer level (render/view_refinement.h).
  std::shared_ptr<const PyramidSource> pyramid;

  float step_world() const {
    const Vec3& s = volume->spacing();
    return step * std::min(s.x, std::min(s.y, s.z));
  }
  float voxel_step() const {  // the smallest voxel edge: what sampling lattices are sized by
    const Vec3& s = volume->spacing();
    return std::min(s.x, std::min(s.y, s.z));
  }
  // The length a transfer-function opacity (and a gradient's shading weight) refers to: one voxel of the
  // data as stored at full resolution (Volume::opacity_length), so that every level of a pyramid looks
  // as its finest does.
  float reference_step() const { return volume->opacity_length(); }
  const TransferFunction& shadow_tf() const {
    return has_shadow_transfer_function ? shadow_transfer_function : transfer_function;
  }
};

// Spheres (atoms, particles) from one file or generator; world units are the file's (ångström for
// molecules).
struct ParticleObject : ShadowFlags {
  std::shared_ptr<const ParticleSet> set;
  std::string source;  // file path or "procedural:random-spheres", for messages and stats
  // particles[].trajectory: `set` is the topology's spheres at frame Scene::time of `frames`, the
  // frame's time in ps as the file stores it. frames = 0: static spheres.
  std::size_t frames = 0;
  double time_ps = 0;
  // What default cameras and lights frame when not empty: a trajectory's topology box, or the first
  // spheres of an array the caller moves (SceneArrays::particle_framing), so that the view holds still
  // while the atoms move. Empty: the spheres' own bounds.
  Box3 topology_bounds;
  // particles[].select: the atoms of the file it kept (at this frame for a trajectory), before
  // hydrogens are dropped and an assembly is built; none without a selection.
  std::optional<std::size_t> selected_atoms;
  // particles[].visible: a hidden set is read (its counts, colour key and cell stay known) but neither
  // drawn nor a caster or receiver of shadows or occlusion, as a hidden volume.
  bool visible = true;
};

// How an isosurface is drawn (paper 002): view-dependent points, the exact ray-cast reference, or the
// full marching-cubes mesh the paper argues against.
enum class IsosurfaceMethod { Points, Raycast, Mesh };
std::string to_string(IsosurfaceMethod method);
IsosurfaceMethod isosurface_method_from_string(const std::string& name);  // "points", "raycast", "mesh"

// The surface {x : f(x) = value} of one of the scene's volumes; inside is f >= value.
struct IsosurfaceObject : ShadowFlags {
  std::size_t volume = 0;   // index into Scene::volumes
  float value = 0;          // isovalue in the volume's data units
  IsosurfaceMethod method = IsosurfaceMethod::Points;
  Rgb color{0.92f, 0.88f, 0.80f};
  bool collapse = true;     // points: a node that projects into one pixel becomes one point (§4.3)
};

// How the sphere renderer finds each pixel's nearest sphere (particles/sphere_hits.h).
enum class SphereRasterizer { Splat, Embree };
std::string to_string(SphereRasterizer r);
SphereRasterizer sphere_rasterizer_from_string(const std::string& s);  // Error listing the names

// A slice's colours (slices[]): each point of the plane inside its volume's box takes the colour of the
// volume's trilinear value there through a colour map (a transfer function's colours; its opacity is
// not read).
struct SliceColors {
  std::shared_ptr<const Volume> volume;
  std::size_t volume_index = 0;  // in Scene::volumes
  TransferFunction color_map;
  Rgb at(const Vec3& p) const { return color_map.evaluate(volume->sample(p)).rgb; }
};

// An opaque plane: a square of edge `size` centred at `point`, or infinite when size is 0. A slice
// (slices[], appended to Scene::planes) is a plane cut to its volume's box and coloured by its values.
struct Plane : ShadowFlags {
  Vec3 point{0, -0.6f, 0};
  Vec3 normal{0, 1, 0};
  Rgb color{0.8f, 0.8f, 0.8f};
  float size = 0;
  // slices[].opacity: below 1 the plane is drawn translucent over what lies behind it (the volumes
  // behind it composited on through it); a translucent plane casts no shadow
  float opacity = 1;
  ClipPlanes clip_planes;   // the scene's clip planes when `clip`, else none (set by the scene reader)
  std::shared_ptr<const SliceColors> slice;  // a slice's colours; null for a plain plane

  Plane() { clip = false; }  // a floor stays whole unless asked

  // Ray parameter of the hit in (tmin, tmax), or infinity.
  float intersect(const Ray& r, float tmin, float tmax) const {
    const float denom = dot(normal, r.direction);
    if (std::abs(denom) < 1e-12f) return kInfinity;
    const float t = dot(point - r.origin, normal) / denom;
    if (!(t > tmin && t < tmax)) return kInfinity;
    if (size > 0) {
      const Frame f = Frame::from_w(normal);
      const Vec3 d = r.at(t) - point;
      if (std::abs(dot(d, f.u)) > size * 0.5f || std::abs(dot(d, f.v)) > size * 0.5f) return kInfinity;
    }
    if (!clip_planes.empty() && clip_planes.removes(r.at(t))) return kInfinity;
    if (slice && !slice->volume->bounds().contains(r.at(t))) return kInfinity;
    return t;
  }
  Rgb color_at(const Vec3& p) const { return slice ? slice->at(p) : color; }
  Box3 bounds() const;  // empty for infinite planes
  // The normal on the side a ray travelling along `direction` sees.
  Vec3 facing_normal(const Vec3& direction) const { return dot(normal, direction) <= 0 ? normal : -normal; }
};

// The nearest of the opaque (or, with `translucent`, the translucent) `planes` that r hits in (0, t),
// or nullptr; t becomes that hit's distance.
inline const Plane* nearest_plane(const std::vector<Plane>& planes, const Ray& r, float& t, bool translucent = false) {
  const Plane* nearest = nullptr;
  for (const auto& p : planes) {
    if ((p.opacity < 1) != translucent) continue;
    const float tp = p.intersect(r, 0, t);
    if (tp < t) {
      t = tp;
      nearest = &p;
    }
  }
  return nearest;
}

struct ShadingParams {
  float ambient = 0.2f;
  float diffuse = 0.8f;
  float specular = 0.25f;
  float shininess = 32;
};

// Which shadow techniques light the scene and the values of their keys. Each technique declares the
// keys it reads, with their defaults and ranges, in its own file (lighting/technique_info.h); the
// scene-file reader checks `params` against those declarations (docs/scene-file.md lists them).
struct ShadowSettings {
  std::string technique = "none";
  TechniqueParams params;  // shadows.resolution, .bias, .offsets, ...: only the keys the scene gives
  // shadows.volumes, .spheres, .isosurfaces, .planes: the technique covering that kind of caster;
  // empty: shadows.technique when it takes the kind, else the kind's default (technique_catalog.h).
  std::array<std::string, kObjectKinds> by_kind;
};

struct AmbientSettings {
  std::string technique = "none";
  TechniqueParams params;  // ambient.radius, .rays, ...: only the keys the scene gives
  bool operator==(const AmbientSettings&) const = default;
};

// The extinction SAT and the light cache of paper 001 (Algorithm 1) share one grid.
struct LightCacheSettings {
  int resolution = 128;    // cells along the volume's longest side (64 … 256 in the paper)
};

struct Scene {
  Camera camera;
  std::vector<VolumeObject> volumes;
  std::vector<ParticleObject> particles;
  std::vector<IsosurfaceObject> isosurfaces;
  SphereRasterizer sphere_rasterizer = SphereRasterizer::Splat;
  std::vector<Plane> planes;  // planes[], then the slices[] (first_slice on)
  std::size_t first_slice = 0;
  // clip_planes: each removes the half-space its normal points into from every object whose `clip` is
  // true, for the eye and for every light (core/clip_planes.h).
  ClipPlanes clip_planes;
  std::vector<Light> lights;
  ShadowSettings shadows;
  AmbientSettings ambient;
  LightCacheSettings light_cache;
  ShadingParams shading;
  Rgb background{0.1f, 0.1f, 0.12f};
  // One line for each key given in the scene that its techniques do not read (scene_file.h); front
  // ends print them.
  std::vector<std::string> unread_keys;
  // The frame shown of every trajectory (particles[].trajectory) and volume series (volumes[].files).
  std::size_t time = 0;
  // memory_budget: bytes the volumes may hold (voxels, macrocells, stored gradients: volume_held_bytes
  // and kGradientBytesPerVoxel), in the order they are read; 0: none. OME-Zarr pyramids open at the
  // finest level that fits what is left, gradients are computed per sample where storing them would not
  // fit, and a volume that cannot fit is an Error (docs/scene-file.md).
  std::uint64_t memory_budget = 0;
  // What the refined views of pyramids (VolumeObject::pyramid) may hold together: what memory_budget
  // leaves after the volumes; without one, a quarter of this machine's memory less what the volumes
  // hold (the rule that chose their levels). Set by the scene reader.
  std::uint64_t refinement_bytes = 0;

  // The frames every dynamic object holds (the smallest count); 0 when nothing moves.
  std::size_t frame_count() const;
  // The box of what the scene shows: the visible volumes, the volumes of isosurfaces and the spheres
  // (a trajectory's topology), finite planes when there are none; default cameras and lights frame it.
  Box3 caster_bounds() const;
  // The first visible volume, or nullptr.
  const VolumeObject* visible_volume() const;
  // The clip planes that cut an object with this `clip` flag (none when false).
  const ClipPlanes& clip_planes_for(bool clip) const;
  bool has_particles() const {  // a visible particle set
    for (const auto& p : particles)
      if (p.visible) return true;
    return false;
  }
  bool has_isosurfaces() const { return !isosurfaces.empty(); }
};

}  // namespace penumbra
