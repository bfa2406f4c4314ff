// The scene file's particles: a molecule or particle file, a trajectory beside its topology, or spheres
// held in memory (docs/scene-file.md, docs/trajectories.md).
#include "penumbra/scene_io/scene_sections.h"

#include <algorithm>
#include <filesystem>

#include "penumbra/data/io/particle_io.h"
#include "penumbra/data/selection/periodic_cell.h"

namespace penumbra::scene_sections {
namespace {

// particles[].select parsed (null when absent); a malformed one is an Error naming the key.
std::shared_ptr<const AtomSelection> read_selection(JsonReader& r) {
  if (!r.has("select")) return nullptr;
  const std::string text = r.required_string("select");
  return with_context(r.key_path("select"), [&] { return parse_selection(text); });
}

// particles[].visible and the shadow flags: a hidden set takes no shadow flags, as a hidden volume.
void read_particle_flags(JsonReader& r, ParticleObject& p) {
  p.visible = r.boolean("visible", true);
  if (!p.visible)
    for (const char* key : {"casts_shadows", "receives_shadows"})
      if (r.has(key)) r.fail(key, "the particle set is not visible ('visible': false): it neither casts nor receives shadows");
  read_shadow_flags(r, p);
}

// The file read once per cache (every particle set naming it shares the reading).
std::shared_ptr<const ParticleFile> particle_file(JsonReader& r, const std::string& file, SceneDataCache& files) {
  return files.particle_file(file, [&] { return with_context(r.key_path("file"), [&] { return read_particle_file(file); }); });
}

// `files`: where files already read are kept.
ParticleObject read_static_particles(const nlohmann::json& j, const std::string& path, const std::string& base_dir,
                                     const SceneReadOptions& options, SceneDataCache& files) {
  if (j.is_object() && j.contains("array")) {  // the caller's spheres, as they are
    JsonReader r(j, path);
    ParticleObject p;
    require_one_source(r);
    p.set = named_array(r, options.arrays, &SceneArrays::particles, "particle");
    p.source = "array:" + r.required_string("array");
    const auto framing = options.arrays->particle_framing.find(r.required_string("array"));
    if (framing != options.arrays->particle_framing.end()) p.topology_bounds = framing->second;
    read_particle_flags(r, p);
    r.finish();
    return p;
  }
  if (options.cache && j.is_object()) {  // everything but the shadow flags defines the spheres and their colours
    JsonReader r(j, path);
    ParticleObject p;
    const std::string key = data_key(j, base_dir, {"casts_shadows", "receives_shadows", "clip", "visible"}, true);
    std::optional<std::size_t>& selected = options.cache->selected_atoms(key);
    p.set = options.cache->particles(key, [&] {
      ParticleObject built = read_static_particles(j, path, base_dir, SceneReadOptions{}, files);
      selected = built.selected_atoms;
      return ParticleSet(*built.set);
    });
    p.selected_atoms = selected;
    p.source = r.has("file") ? resolve(base_dir, r.required_string("file")) : "procedural:random-spheres";
    read_particle_flags(r, p);
    return p;
  }
  JsonReader r(j, path);
  ParticleObject p;
  require_one_source(r);
  const bool has_file = r.has("file");
  if (has_file) {
    const std::string file = resolve(base_dir, r.required_string("file"));
    ParticleLoadOptions o;
    o.selection = read_selection(r);
    o.assembly = static_cast<int>(r.integer("assembly", 0, 0, 1000000));
    const std::string color_by = r.string("color_by", "element");
    o.coloring = with_context(r.key_path("color_by"), [&] { return particle_coloring_from_string(color_by); });
    o.uniform_color = r.color("color", o.uniform_color);
    if (r.has("color") && o.coloring != ParticleColoring::Uniform)
      r.fail("color", "is used only with \"color_by\": \"uniform\"");
    if (o.coloring == ParticleColoring::Scalar) {
      o.scalar = with_context(r.key_path("scalar"), [&] { return particle_scalar_from_string(r.string("scalar", "b_factor")); });
      if (r.has("color_map")) {
        const nlohmann::json spec = r.raw("color_map");
        const std::string where = r.key_path("color_map");
        o.color_map = [spec, where, base_dir](float lo, float hi) {
          return with_context(where, [&] { return parse_transfer_function(spec, lo, hi, base_dir); });
        };
      }
    } else {
      for (const char* key : {"scalar", "color_map"})
        if (r.has(key)) r.fail(key, "is used only with \"color_by\": \"scalar\"");
    }
    if (r.has("radius") && r.has("radius_scale"))
      r.fail("radius", "give 'radius' (one radius for every sphere) or 'radius_scale' (scales the element radii), not both");
    o.radius_scale = r.number("radius_scale", o.radius_scale, 0.01f, 100);
    o.hydrogens = r.boolean("hydrogens", o.hydrogens);
    const std::shared_ptr<const ParticleFile> atoms = particle_file(r, file, files);
    ParticleFileInfo info;
    ParticleSet set = with_context(r.key_path("file"), [&] { return build_particles(*atoms, o, &info); });
    if (o.selection) {
      p.selected_atoms = info.selected_atoms;
      if (info.selected_atoms == 0) r.fail("select", "selects no atoms of '" + file + "'");
      if (set.size() == 0) r.fail("select", "selects only hydrogens, which \"hydrogens\": false drops");
    }
    // One radius for every sphere (beads, SPH particles, coarse-grained models have no element radii).
    if (r.has("radius")) {
      const float radius = r.number("radius", 1, 1e-6f, 1e6f);
      for (Sphere& sp : set.spheres) sp.radius = radius;
    }
    p.set = std::make_shared<ParticleSet>(std::move(set));
    p.source = file;
  } else {
    if (r.has("radius")) r.fail("radius", "generated spheres take their radius inside 'procedural'");
    if (r.has("select")) r.fail("select", "selects atoms of a file; generated spheres have none");
    const std::string color_by = r.string("color_by", "hue");
    if (color_by != "hue" && color_by != "uniform")
      r.fail("color_by", "generated spheres are coloured by \"hue\" (a hashed hue per sphere, the default) or \"uniform\" (one 'color'), not '" + color_by + "'");
    if (r.has("color") && color_by != "uniform") r.fail("color", "is used only with \"color_by\": \"uniform\"");
    const Rgb color = r.color("color", Rgb{0.8f, 0.8f, 0.8f});
    JsonReader g(r.raw("procedural"), r.key_path("procedural"));
    const std::string name = g.required_string("name");
    if (name != "random-spheres") g.fail("name", "unknown particle generator '" + name + "' (expected random-spheres)");
    const auto count = static_cast<std::size_t>(g.integer("count", 1000, 1, 100000000));
    const float radius = g.number("radius", 0.02f, 1e-6f, 1);
    const auto seed = static_cast<std::uint64_t>(g.integer("seed", 1, 0, INT64_MAX));
    g.finish();
    ParticleSet set = random_spheres(count, radius, seed);
    set.color_key.by = color_by;  // a hue per sphere: no key
    if (color_by == "uniform") {
      std::fill(set.colors.begin(), set.colors.end(), pack_rgba8(color));
      set.color_key.entries = {{"all spheres", pack_rgba8(color), set.size()}};
    }
    p.set = std::make_shared<ParticleSet>(std::move(set));
    p.source = "procedural:random-spheres";
  }
  if (r.has("origin")) {  // moves the set so that its bounding box's centre is here
    const Vec3 o = r.vec3("origin", {});
    auto moved = std::make_shared<ParticleSet>(*p.set);
    const Vec3 shift = o - p.set->bounds().center();
    for (auto& sp : moved->spheres) sp.center = sp.center + shift;
    if (moved->box) moved->box->origin = moved->box->origin + shift;
    p.set = std::move(moved);
  }
  if (p.set->size() == 0) r.fail(has_file ? "file" : "procedural", "holds no particles");
  read_particle_flags(r, p);
  r.finish();
  return p;
}

// The files of particles[].trajectory: one file or a list (frames in the order given), resolved.
std::vector<std::string> trajectory_files(JsonReader& r, const std::string& base_dir) {
  const nlohmann::json& t = r.raw("trajectory");
  std::vector<std::string> files;
  if (t.is_string()) files.push_back(resolve(base_dir, t.get<std::string>()));
  if (t.is_array())
    for (const auto& f : t) {
      if (!f.is_string()) r.fail("trajectory", "lists file names (strings)");
      files.push_back(resolve(base_dir, f.get<std::string>()));
    }
  if (files.empty()) r.fail("trajectory", "expected a file name or a non-empty list of file names");
  return files;
}

// The spheres of `set` (sphere i: atom i) at `indices`, in that order, each naming its atom.
ParticleSet pick_spheres(const ParticleSet& set, const std::vector<std::uint32_t>& indices) {
  ParticleSet out;
  out.atoms = indices;
  out.spheres.reserve(indices.size());
  out.colors.reserve(indices.size());
  for (const std::uint32_t i : indices) {
    out.spheres.push_back(set.spheres[i]);
    out.colors.push_back(set.colors[i]);
  }
  out.color_key = set.color_key;
  recount(out.color_key, out.colors);
  out.box = set.box;
  return out;
}

// particles[] with a "trajectory": the topology (its `file`, read as a static set: radii, colours) with
// every sphere moved to its atom's position at frame `time` (sphere i is atom i, so the topology keeps
// every atom: no assembly, hydrogens kept), then the atoms its `select` keeps: a selection that depends
// on positions (around, sphzone, within) evaluated at this frame with the frame's box, others once.
// The trajectory stays open in the cache between frames.
ParticleObject read_trajectory_particles(const nlohmann::json& j, const std::string& path, const std::string& base_dir,
                                         const SceneReadOptions& options, std::size_t time, SceneDataCache& files) {
  JsonReader r(j, path);
  if (!r.has("file")) r.fail("trajectory", "needs a topology: give the particles' 'file' (PDB, mmCIF, GRO or XYZ) beside it");
  if (r.integer("assembly", 0, 0, 1000000) != 0)
    r.fail("assembly", "cannot be used with a trajectory: its frames hold the deposited atoms, not an assembly");
  if (!r.boolean("hydrogens", true))
    r.fail("hydrogens", "cannot be false with a trajectory: its frames hold every atom of the topology");
  const std::vector<std::string> trajectory_paths = trajectory_files(r, base_dir);
  const std::shared_ptr<const AtomSelection> selection = read_selection(r);
  nlohmann::json topology_json = j;
  topology_json.erase("trajectory");
  topology_json.erase("origin");  // the shift is applied to every frame below
  topology_json.erase("select");  // applied to every frame below
  ParticleObject p = read_static_particles(topology_json, path, base_dir, options, files);
  const std::shared_ptr<const ParticleSet> topology_set = p.set;  // p.set becomes the frame below
  const ParticleSet& topology = *topology_set;
  auto open = [&] {
    return with_context(r.key_path("trajectory"), [&] { return open_trajectory(trajectory_paths, topology.size()); });
  };
  std::unique_ptr<TrajectoryReader> own;
  TrajectoryReader& reader = options.cache ? options.cache->trajectory(nlohmann::json(trajectory_paths).dump(), open) : *(own = open());
  if (reader.atom_count() != topology.size())
    r.fail("trajectory", "holds " + std::to_string(reader.atom_count()) + " atoms a frame, but the topology '" +
                             p.source + "' has " + std::to_string(topology.size()));
  if (time >= reader.frame_count())
    throw Error("time: frame " + std::to_string(time) + " is past the last frame of " + r.key_path("trajectory") + " (" +
                std::to_string(reader.frame_count()) + " frames, 0 to " + std::to_string(reader.frame_count() - 1) + ")");

  // The selection on the topology file's own coordinates: the atoms a static selection keeps, and
  // what the default camera frames.
  std::shared_ptr<const ParticleFile> atoms;
  std::shared_ptr<const std::vector<std::uint32_t>> topology_selected;
  if (selection) {
    atoms = particle_file(r, p.source, files);
    const auto evaluate = [&] {
      return selection->evaluate(topology_of(*atoms), positions_of(*atoms), topology_of(*atoms).unit_cell);
    };
    topology_selected = options.cache ? options.cache->selected_indices(p.source + "|" + selection->text(), evaluate)
                                      : std::make_shared<const std::vector<std::uint32_t>>(evaluate());
  }
  const Box3 shown = topology_selected ? pick_spheres(topology, *topology_selected).bounds() : topology.bounds();
  const Vec3 shift = r.has("origin") ? r.vec3("origin", {}) - shown.center() : Vec3{};
  double time_ps = 0;
  std::optional<std::size_t> selected;
  auto load_frame = [&] {
    TrajectoryFrame frame;
    with_context(r.key_path("trajectory"), [&] { reader.read_frame(time, frame); });
    time_ps = frame.time_ps;
    ParticleSet moved = topology;
    for (std::size_t i = 0; i < moved.spheres.size(); ++i) moved.spheres[i].center = frame.positions[i] + shift;
    moved.box.reset();  // the frame's cell, as MDAnalysis's ts.dimensions (none where the frame stores none)
    if (const std::optional<PeriodicCell> cell = periodic_cell(frame.has_box ? std::optional<CellDimensions>(frame.box) : std::nullopt))
      moved.box = PeriodicBox{shift, cell->a, cell->b, cell->c};
    if (!selection) return moved;
    const std::vector<std::uint32_t> indices =
        selection->depends_on_positions()
            ? selection->evaluate(topology_of(*atoms), frame.positions, frame.has_box ? std::optional<CellDimensions>(frame.box) : std::nullopt)
            : *topology_selected;
    if (indices.empty()) r.fail("select", "selects no atoms at frame " + std::to_string(time));
    selected = indices.size();
    return pick_spheres(moved, indices);
  };
  // a frame read once per time: edits of anything else keep the same spheres
  if (options.cache) {
    std::string key = data_key(j, base_dir, {"casts_shadows", "receives_shadows", "clip", "visible"}, true) + "@time=" + std::to_string(time);
    bool loaded = false;
    p.set = options.cache->particles(key, [&] {
      loaded = true;
      return load_frame();
    });
    double& stored = options.cache->frame_time_ps(key);
    std::optional<std::size_t>& stored_selected = options.cache->selected_atoms(key);
    if (loaded) {
      stored = time_ps;
      stored_selected = selected;
    }
    p.time_ps = stored;
    p.selected_atoms = stored_selected;
  } else {
    p.set = std::make_shared<const ParticleSet>(load_frame());
    p.time_ps = time_ps;
    p.selected_atoms = selected;
  }
  p.topology_bounds = shown;
  if (r.has("origin")) {
    p.topology_bounds.lo = p.topology_bounds.lo + shift;
    p.topology_bounds.hi = p.topology_bounds.hi + shift;
  }
  p.frames = reader.frame_count();
  return p;
}

}  // namespace

ParticleObject read_particles(const nlohmann::json& j, const std::string& path, const std::string& base_dir,
                              const SceneReadOptions& options, std::size_t time, SceneDataCache& files) {
  if (j.is_object() && j.contains("trajectory")) return read_trajectory_particles(j, path, base_dir, options, time, files);
  return read_static_particles(j, path, base_dir, options, files);
}

}  // namespace penumbra::scene_sections
