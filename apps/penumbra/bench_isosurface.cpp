// `penumbra bench --suite isosurface`: paper 002's Table 1 (Livnat & Tricoche: cull time, render time,
// points and frames per second, with and without shadows) on this machine, for two views of two
// isovalues of a Visible-Woman-sized volume (the procedural "ct-body", 512×512×1734 uint16) and of the
// CT files — plus what the paper lacks: coverage, depth error and shadow disagreement of the points
// against the exact ray-cast isosurface with exact shadow rays, and the marching-cubes baseline (mesh
// extraction time, triangles, rasterisation time) the paper argues points beat.
#include "bench_isosurface.h"
#include "bench_format.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <memory>
#include <unordered_map>

#include "penumbra/core/error.h"
#include "penumbra/core/image_io.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/render/isosurface_frame.h"
#include "penumbra/render/light_shadows.h"
#include "penumbra/render/surface_frame.h"
#include "penumbra/scene_io/scene_file.h"

namespace penumbra::cli {
namespace {

struct View {
  const char* name;
  Vec3 direction;    // from the target towards the eye
  Vec3 target;       // a fraction of the volume box (0 … 1 per axis)
  float zoom;        // 1: the whole volume fits the frame
};

struct Isovalue {
  const char* name;
  float value;
};

struct IsosurfaceDataset {
  std::string name;
  nlohmann::json volume;  // the scene file's volumes[0]
  std::vector<Isovalue> isovalues;
  std::vector<View> views;
  Vec3 up{0, 0, 1};
};

std::vector<IsosurfaceDataset> datasets(const IsosurfaceBenchOptions& o) {
  const nlohmann::json dims = {o.body_dims[0], o.body_dims[1], o.body_dims[2]};
  return {
      {"ct-body",
       {{"procedural", {{"name", "ct-body"}, {"dims", dims}}}, {"visible", false}},
       {{"skin", 500}, {"bone", 1400}},
       {{"skull", {0.2f, -1.0f, 0.25f}, {0.5f, 0.5f, 0.9f}, 4.5f}, {"torso", {0.45f, -1.0f, 0.3f}, {0.5f, 0.5f, 0.62f}, 2.2f}}},
      {"cranium",
       {{"file", o.data_dir + "/cranium_ct.nrrd"}, {"visible", false}},
       {{"skin", -400}, {"bone", 400}},
       {{"front", {0.35f, 1.0f, 0.45f}, {0.5f, 0.5f, 0.5f}, 1.0f}, {"side", {-1.0f, 0.2f, 0.3f}, {0.5f, 0.5f, 0.5f}, 1.2f}}},
      {"chest",
       {{"file", o.data_dir + "/chest_ct.nrrd"}, {"visible", false}},
       {{"skin", 25}, {"bone", 110}},
       {{"front", {0.3f, 1.0f, 0.4f}, {0.5f, 0.5f, 0.5f}, 1.0f}, {"back", {-0.3f, -1.0f, 0.2f}, {0.5f, 0.5f, 0.5f}, 1.0f}}},
  };
}

Camera framed(const Box3& box, const View& v, const Vec3& up, int size) {
  Camera c;
  c.fov_deg = 35;
  c.width = c.height = size;
  c.up = up;
  const Vec3 e = box.extent();
  c.target = box.lo + Vec3{e.x * v.target.x, e.y * v.target.y, e.z * v.target.z};
  const float distance = box.radius() / std::sin(radians(c.fov_deg) * 0.5f) / v.zoom;
  c.eye = c.target + normalize(v.direction) * distance;
  return c;
}

struct Run {
  double cull_ms = 0, shadow_ms = 0, render_ms = 0;
  std::size_t points = 0, light_points = 0, holes = 0;
  Image image;
  VisibleSurfaces surfaces;     // the shaded points (isosurface and planes), in pixel order
  std::vector<float> fraction;  // per receiver, the first light's transmittance
  double total() const { return cull_ms + shadow_ms + render_ms; }
};

// The fastest of `repeats` frames of the one isosurface `iso` (the scene's isosurface 0), as the
// renderer draws them: the eye pass (cull), each light's shadows built and fitted to the frame's
// receivers (shadow: paper 002 §4, the light pass answers only for the eye's points), then the
// visible surfaces picked and shaded under those shadows (render).
Run run_frames(const Scene& scene_in, const Camera& camera, PreparedIsosurface& iso, int repeats) {
  Scene scene = scene_in;  // the volumes are shared, not copied
  scene.isosurfaces = {*iso.object};
  const std::vector<const MacrocellGrid*> no_grids(scene.volumes.size(), nullptr);  // the volume is not drawn
  ShadowCasters casters(scene, no_grids);
  casters.add_isosurface(iso.raycaster, *iso.tree, 0);
  Run best;
  for (int r = 0; r < repeats; ++r) {
    IsosurfaceFrameStats stats;
    Run run;
    const IsoPoints eye = isosurface_eye_points(camera, iso, stats);
    run.cull_ms = stats.extract_ms;
    run.points = eye.size();
    Timer shade;
    const SurfaceInputs in{&scene, &camera, nullptr, {}, {}, nullptr, std::span<const IsoPoints>(&eye, 1)};
    run.surfaces = visible_surfaces(in);
    run.render_ms = shade.elapsed_ms();
    Timer shadow_timer;
    std::vector<std::unique_ptr<LightShadows>> shadows;
    ShadowStats shadow_stats;
    for (const Light& light : scene.lights) {
      shadows.push_back(std::make_unique<LightShadows>(scene, casters, light));
      shadows.back()->fit_to_receivers(run.surfaces.points, false, false);
      shadows.back()->add_stats(shadow_stats);
    }
    run.shadow_ms = shadow_timer.elapsed_ms();
    run.light_points = shadow_stats.light_points;
    run.holes = shadow_stats.holes;
    shade.reset();
    std::vector<const LightShadows*> shadow_ptrs;
    for (const auto& l : shadows) shadow_ptrs.push_back(l.get());
    run.image = shade_surfaces(scene, camera, run.surfaces, scene.lights, shadow_ptrs, nullptr);
    run.render_ms += shade.elapsed_ms();
    // the first light's transmittance at every receiver, for the comparison (not timed)
    const std::vector<SurfacePoint>& pts = run.surfaces.points;
    run.fraction.assign(pts.size(), 1.0f);
    if (!shadows.empty()) {
      std::vector<Rgb> t(pts.size());
      parallel_for(pts.size(), [&](std::size_t b, std::size_t e) {
        shadows[0]->transmittance(std::span<const SurfacePoint>(pts).subspan(b, e - b), std::span<Rgb>(t).subspan(b, e - b));
      }, 1024);
      for (std::size_t i = 0; i < pts.size(); ++i) run.fraction[i] = t[i].max_component();
    }
    if (r == 0 || run.total() < best.total()) best = std::move(run);
  }
  return best;
}

struct Agreement {
  double coverage = 0;        // reference pixels the points cover
  double extra = 0;           // point pixels the reference leaves empty, per reference pixel
  double depth_voxels = 0;    // median |depth difference| on common pixels, in voxels
  double disagreement = 0;    // common light-facing pixels whose lit/shadowed state differs
  Image map;                  // grey: agree; red: shadowed by the points only; blue: by the reference only
};

Agreement compare(const Run& points, const Run& reference, const Light& light, float voxel) {
  Agreement a;
  a.map = Image(points.image.width(), points.image.height(), Rgb(0.0f));
  std::unordered_map<std::uint32_t, std::size_t> ref;
  for (std::size_t i = 0; i < reference.surfaces.points.size(); ++i) ref[reference.surfaces.pixel[i]] = i;
  std::size_t common = 0, facing = 0, differ = 0;
  std::vector<float> depth;
  for (std::size_t i = 0; i < points.surfaces.points.size(); ++i) {
    const std::uint32_t pixel = points.surfaces.pixel[i];
    const auto it = ref.find(pixel);
    if (it == ref.end()) continue;
    ++common;
    const SurfacePoint& q = reference.surfaces.points[it->second];
    depth.push_back(std::abs(points.surfaces.distance[pixel] - reference.surfaces.distance[pixel]) / voxel);
    Vec3 to_light;
    float d;
    light.towards(q.position, to_light, d);
    if (dot(q.normal, to_light) <= 0) continue;
    ++facing;
    const bool lit = points.fraction[i] > 0, lit_ref = reference.fraction[it->second] > 0;
    differ += lit != lit_ref;
    const int w = a.map.width();
    a.map.at(static_cast<int>(pixel % static_cast<std::uint32_t>(w)), static_cast<int>(pixel / static_cast<std::uint32_t>(w))) =
        lit == lit_ref ? Rgb(lit ? 0.8f : 0.35f) : (lit_ref ? Rgb(1, 0.1f, 0.1f) : Rgb(0.2f, 0.4f, 1));
  }
  const double n = static_cast<double>(std::max<std::size_t>(ref.size(), 1));
  a.coverage = static_cast<double>(common) / n;
  a.extra = static_cast<double>(points.surfaces.points.size() - common) / n;
  if (!depth.empty()) {
    std::nth_element(depth.begin(), depth.begin() + static_cast<std::ptrdiff_t>(depth.size() / 2), depth.end());
    a.depth_voxels = depth[depth.size() / 2];
  }
  a.disagreement = facing ? static_cast<double>(differ) / static_cast<double>(facing) : 0;
  return a;
}

void bench_dataset(const IsosurfaceBenchOptions& o, const IsosurfaceDataset& d, std::ostringstream& md, nlohmann::json& out) {
  std::fprintf(stderr, "bench isosurface %s: loading...\n", d.name.c_str());
  nlohmann::json j;
  j["volumes"] = nlohmann::json::array({d.volume});
  j["isosurfaces"] = nlohmann::json::array({{{"value", d.isovalues[0].value}}});
  j["lights"] = nlohmann::json::array({{{"type", "point"}, {"position", {0, 0, 0}}}});
  Timer load;
  Scene scene = build_scene(j, "");
  const double load_ms = load.elapsed_ms();
  const Volume& volume = *scene.volumes[0].volume;
  const Box3 box = volume.bounds();
  Timer tree_timer;
  const auto tree = std::make_shared<const GridTree>(volume);
  const double tree_ms = tree_timer.elapsed_ms();
  const float voxel = std::min({volume.spacing().x, volume.spacing().y, volume.spacing().z});
  const auto& dims = volume.dims();

  char line[768];
  std::snprintf(line, sizeof line,
                "\n### %s: %d×%d×%d %s, %.0f MB\n\nLoad or generation %.0f ms; min/max hierarchy (GridTree) %.0f ms, "
                "%.1f MB. Frame and light buffer %d². Cull = extraction from the eye (+ the light pass with "
                "shadows); render = shading the points.\n\n",
                d.name.c_str(), dims[0], dims[1], dims[2], to_string(volume.type()).c_str(),
                static_cast<double>(volume.memory_bytes()) / 1e6, load_ms, tree_ms,
                static_cast<double>(tree->memory_bytes()) / 1e6, o.size);
  md << line;
  md << "| isovalue | view | shadows | cull ms | render ms | points | light points | fps |\n|---|---|---|---:|---:|---:|---:|---:|\n";
  std::ostringstream quality;
  quality << "| isovalue | view | coverage | extra | depth error (voxels) | shadow disagreement | ray cast + rays ms | "
             "MC ms | triangles | mesh raster ms | (MC + raster) / points |\n|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  nlohmann::json jd;
  jd["load_ms"] = load_ms;
  jd["grid_tree_ms"] = tree_ms;
  jd["grid_tree_bytes"] = tree->memory_bytes();
  jd["voxels"] = volume.voxel_count();
  for (const Isovalue& iso : d.isovalues) {
    IsosurfaceObject points_obj;  // volume 0, casts and receives shadows, collapse
    points_obj.value = iso.value;
    points_obj.method = IsosurfaceMethod::Points;
    points_obj.color = {0.92f, 0.88f, 0.80f};
    IsosurfaceObject ray_obj = points_obj;
    ray_obj.method = IsosurfaceMethod::Raycast;
    IsosurfaceObject mesh_obj = points_obj;
    mesh_obj.method = IsosurfaceMethod::Mesh;
    PreparedIsosurface points(tree, points_obj), reference(tree, ray_obj), mesh(tree, mesh_obj);
    double mc_ms = 0;
    for (const View& v : d.views) {
      std::fprintf(stderr, "bench isosurface %s: %s, %s...\n", d.name.c_str(), iso.name, v.name);
      const Camera cam = framed(box, v, d.up, o.size);
      Scene s = scene;
      // a point light beside and above the viewer, well outside the volume: shadows fall visibly
      const Vec3 dir = normalize(v.direction), right = normalize(cross(d.up, dir));
      s.lights[0].position = cam.target + normalize(dir + right * 0.9f + normalize(d.up) * 0.7f) * (2.5f * box.radius());
      s.shadows.params.set("resolution", o.size);
      s.shadows.technique = "none";
      const Run plain = run_frames(s, cam, points, o.repeats);
      s.shadows.technique = "light_pass";
      const Run shadowed = run_frames(s, cam, points, o.repeats);
      s.shadows.technique = "ray_traced";
      const Run exact = run_frames(s, cam, reference, 1);
      Run meshed;
      if (o.mesh) {
        s.shadows.technique = "none";
        IsosurfaceFrameStats ms;
        (void)isosurface_eye_points(cam, mesh, ms);  // marching cubes on the first view, then rasterisation
        if (ms.mesh_ms > 0) mc_ms = ms.mesh_ms;
        meshed.cull_ms = ms.extract_ms;
        meshed.points = ms.triangles;
      }
      const Agreement a = compare(shadowed, exact, s.lights[0], voxel);
      const std::string stem = o.dir + "/iso_" + d.name + "_" + iso.name + "_" + v.name;
      write_image(stem + "_points.png", plain.image);
      write_image(stem + "_light_pass.png", shadowed.image);
      write_image(stem + "_ray_traced.png", exact.image);
      write_image(stem + "_disagreement.png", a.map);
      for (const Run* r : {&plain, &shadowed}) {
        const bool sh = r == &shadowed;
        std::snprintf(line, sizeof line, "| %s %g | %s | %s | %.1f | %.1f | %zu | %s | %.1f |\n", iso.name,
                      static_cast<double>(iso.value), v.name, sh ? "light_pass" : "none", r->cull_ms + r->shadow_ms,
                      r->render_ms, r->points, sh ? std::to_string(r->light_points).c_str() : "—", 1000.0 / r->total());
        md << line;
      }
      const double points_ms = plain.cull_ms + plain.render_ms;
      quality << "| " << iso.name << " " << iso.value << " | " << v.name << " | " << fmt("%.4f", a.coverage) << " | "
              << fmt("%.4f", a.extra) << " | " << fmt("%.2f", a.depth_voxels) << " | " << fmt("%.4f", a.disagreement)
              << " | " << fmt("%.0f", exact.total()) << " | "
              << (o.mesh ? fmt("%.0f", mc_ms) + " | " + std::to_string(meshed.points) + " | " + fmt("%.0f", meshed.cull_ms) +
                               " | " + fmt("%.1f×", (mc_ms + meshed.cull_ms) / points_ms)
                         : std::string("— | — | — | —"))
              << " |\n";
      jd["runs"].push_back({{"isovalue", iso.value}, {"isovalue_name", iso.name}, {"view", v.name},
                            {"cull_ms", plain.cull_ms}, {"render_ms", plain.render_ms}, {"points", plain.points},
                            {"fps", 1000.0 / plain.total()},
                            {"shadows", {{"cull_ms", shadowed.cull_ms + shadowed.shadow_ms}, {"render_ms", shadowed.render_ms},
                                         {"light_points", shadowed.light_points}, {"holes", shadowed.holes},
                                         {"fps", 1000.0 / shadowed.total()}}},
                            {"shadow_cost", shadowed.total() / plain.total()},
                            {"coverage", a.coverage}, {"extra", a.extra}, {"depth_error_voxels", a.depth_voxels},
                            {"shadow_disagreement", a.disagreement}, {"raycast_ms", exact.total()},
                            {"mc_ms", mc_ms}, {"triangles", meshed.points}, {"mesh_raster_ms", meshed.cull_ms}});
    }
  }
  md << "\n" << quality.str();
  out[d.name] = jd;
}

}  // namespace

void bench_isosurface(const IsosurfaceBenchOptions& o, std::ostringstream& md, nlohmann::json& out) {
  md << "\n## Point-based isosurfaces with light-pass shadows (paper 002, Table 1) on this machine\n";
  const auto all = datasets(o);
  for (const std::string& name : o.datasets) {
    const auto it = std::find_if(all.begin(), all.end(), [&](const IsosurfaceDataset& d) { return d.name == name; });
    if (it == all.end()) throw Error("--isosurface-datasets: unknown data set '" + name + "' (expected ct-body, cranium or chest)");
    if (it->volume.contains("file") && !std::filesystem::exists(it->volume["file"].get<std::string>()))
      throw Error("--isosurface-datasets " + name + ": " + it->volume["file"].get<std::string>() + " not found (see --data-dir)");
    bench_dataset(o, *it, md, out);
  }
}

}  // namespace penumbra::cli
