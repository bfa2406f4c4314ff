// `penumbra bench --suite particles`: paper 003's (Implicit Sphere Shadow Maps, Krone et al.) Fig. 8 on
// this machine — frame rates at 1920×1200 with a 512² map for local lighting (LL), ISSM and ISSM + AO on
// molecules of 5 k to 16 M atoms — plus what the paper lacks: the first frame's build times, frames with
// a moving light (the ISSM rebuilt every frame), load time and memory, both sphere rasterizers (splat,
// Embree), and error (RMSE, PSNR, shadow disagreement) against the exact ray-traced references.
#include <algorithm>
#include <malloc.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <memory>
#include <span>
#include <sstream>

#include "bench_particles.h"
#include "bench_format.h"
#include "penumbra/core/error.h"
#include "penumbra/core/image_io.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/particles/implicit_sphere_shadow_map.h"
#include "penumbra/geometry/sphere_bvh.h"
#include "penumbra/particles/sphere_hits.h"
#include "penumbra/registry/technique_catalog.h"
#include "penumbra/render/renderer.h"
#include "penumbra/render/surface_frame.h"
#include "penumbra/scene_io/demo_scenes.h"
#include "penumbra/scene_io/scene_file.h"
#include "penumbra/shadows/ray_traced.h"

namespace penumbra::cli {
namespace {

struct ParticleDataset {
  const char* name;
  const char* file;
  int assembly;  // 0: the deposited coordinates
};

constexpr ParticleDataset kDatasets[] = {
    {"1tii", "1tii.pdb", 0},   {"1af6", "1af6.pdb", 0}, {"1aon", "1aon.pdb.gz", 0}, {"bace1", "bace1_dppc.gro.gz", 0},
    {"3j6r", "3j6r.pdb.gz", 1}, {"1m4x", "1m4x.pdb.gz", 1}};

const ParticleDataset& find_dataset(const std::string& name) {
  for (const auto& d : kDatasets)
    if (name == d.name) return d;
  std::string names;
  for (const auto& d : kDatasets) names += std::string(names.empty() ? "" : ", ") + d.name;
  throw Error("--particle-datasets: unknown data set '" + name + "' (expected " + names + ")");
}

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

std::string mib(std::size_t bytes) { return fmt("%.1f", static_cast<double>(bytes) / 1048576.0); }

std::string size_str(int w, int h) { return std::to_string(w) + "×" + std::to_string(h); }

double median(std::vector<double> v) {
  if (v.empty()) return kNaN;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// Peak resident memory of the process (VmHWM), reset per data set through /proc/self/clear_refs where
// the kernel allows it.
bool reset_peak_rss() {
  std::ofstream f("/proc/self/clear_refs");
  f << "5";
  f.flush();
  return static_cast<bool>(f);
}

std::size_t proc_status_kib(const char* key) {
  std::ifstream in("/proc/self/status");
  std::string line;
  const std::string k = std::string(key) + ":";
  while (std::getline(in, line))
    if (line.rfind(k, 0) == 0) return std::stoull(line.substr(k.size()));
  return 0;
}

// The scene of paper 003's figures (scenes/1tii.json) for one particle file: the demo's molecule scene,
// framed as the scene files frame it (no zoom).
nlohmann::json particle_scene_json(const std::string& file, int assembly, int width, int height) {
  nlohmann::json j = molecule_scene(file);
  if (assembly) j["particles"][0]["assembly"] = assembly;
  j["camera"].erase("zoom");
  j["camera"]["width"] = width;
  j["camera"]["height"] = height;
  return j;
}

// The loaded scene with other techniques and frame size (the particle set is shared, not copied).
Scene variant(const Scene& base, const std::string& shadows, const std::string& ambient, int width, int height,
              int rings = 1, SphereRasterizer rasterizer = SphereRasterizer::Splat) {
  Scene s = base;
  s.shadows.technique = shadows;
  s.shadows.params.set("rings", rings);
  s.ambient.technique = ambient;
  if (ambient == "ray_traced_ao") s.ambient.params.set("rays", 64);
  s.camera.width = width;
  s.camera.height = height;
  s.sphere_rasterizer = rasterizer;
  return s;
}

// The light turned by `degrees` about the vertical axis.
Light turned(Light l, float degrees) {
  const float a = radians(degrees), c = std::cos(a), s = std::sin(a);
  const Vec3 d = l.direction;
  l.direction = normalize(Vec3{d.x * c - d.z * s, d.y, d.x * s + d.z * c});
  return l;
}

struct FrameRun {
  FrameResult first;  // the first frame: its build times and image
  int frames = 0;     // cached frames timed
  double cached_ms = kNaN, cached_render_ms = kNaN, cached_hits_ms = kNaN, fastest_ms = kNaN;
  double moving_ms = kNaN, moving_build_ms = kNaN;
  std::size_t shadow_bytes = 0, ambient_bytes = 0, bvh_bytes = 0;
};

// One configuration being timed: its renderer and the frame times so far.
struct Timing {
  Timing(Scene s, bool moving_light_) : scene(std::move(s)), moving_light(moving_light_) {}
  Scene scene;
  bool moving_light;
  std::unique_ptr<Renderer> renderer;
  FrameRun run;
  std::vector<double> total, render, hits, moving, build;
};

// The first frame of every configuration (with its builds), then `repeats` rounds of one cached frame
// of every configuration in turn, then — for those with `moving_light` — `repeats` rounds of frames
// whose light turns by 1° more each time, so that the shadows are rebuilt. Medians per configuration.
// Interleaving the configurations spreads what other processes on the machine take from the cores
// over all of them alike, which keeps their ratios meaningful.
void run_interleaved(const std::vector<Timing*>& timings, int repeats) {
  for (Timing* t : timings) {
    t->renderer = std::make_unique<Renderer>(t->scene);
    t->run.first = t->renderer->render();
  }
  for (int i = 0; i < repeats; ++i)
    for (Timing* t : timings) {
      const FrameResult f = t->renderer->render();
      if (!f.rebuilt.empty()) throw Error("bench particles: a frame with nothing changed rebuilt " + f.rebuilt.front());
      t->total.push_back(f.total_ms);
      t->render.push_back(f.render_ms);
      t->hits.push_back(f.hits_ms);
    }
  for (int i = 1; i <= repeats; ++i)
    for (Timing* t : timings) {
      if (!t->moving_light) continue;
      std::vector<Light> lights = t->scene.lights;
      lights[0] = turned(lights[0], static_cast<float>(i));
      const FrameResult f = t->renderer->render(t->scene.camera, lights);
      if (std::find(f.rebuilt.begin(), f.rebuilt.end(), "lights.0.shadows") == f.rebuilt.end())
        throw Error("bench particles: a moved light did not rebuild the shadows");
      t->moving.push_back(f.total_ms);
      t->build.push_back(f.build_ms);
    }
  for (Timing* t : timings) {
    FrameRun& run = t->run;
    run.frames = repeats;
    run.cached_ms = median(t->total);
    run.fastest_ms = t->total.empty() ? kNaN : *std::min_element(t->total.begin(), t->total.end());
    run.cached_render_ms = median(t->render);
    run.cached_hits_ms = median(t->hits);
    run.moving_ms = median(t->moving);
    run.moving_build_ms = median(t->build);
    run.shadow_bytes = t->renderer->shadow_memory_bytes();
    run.ambient_bytes = t->renderer->ambient_memory_bytes();
    run.bvh_bytes = t->renderer->bvh_memory_bytes();
    t->renderer.reset();
  }
}

FrameRun run_frames(const Scene& scene, int repeats, bool moving_light) {
  Timing t(scene, moving_light);
  run_interleaved({&t}, repeats);
  return std::move(t.run);
}

nlohmann::json run_json(const FrameRun& r, int width, int height) {
  const FrameResult& f = r.first;
  auto num = [](double v) { return std::isnan(v) ? nlohmann::json(nullptr) : nlohmann::json(v); };
  return {{"width", width},
          {"height", height},
          {"first_frame",
           {{"total_ms", f.total_ms}, {"bvh_ms", f.bvh_ms}, {"ambient_ms", f.ambient_ms}, {"shadow_build_ms", f.build_ms},
            {"render_ms", f.render_ms}, {"hits_ms", f.hits_ms}}},
          {"cached_frames", r.frames},
          {"cached_ms", num(r.cached_ms)},
          {"cached_fastest_ms", num(r.fastest_ms)},
          {"cached_render_ms", num(r.cached_render_ms)},
          {"cached_hits_ms", num(r.cached_hits_ms)},
          {"moving_light_ms", num(r.moving_ms)},
          {"moving_light_shadow_build_ms", num(r.moving_build_ms)},
          {"issm_rings", f.issm_rings},
          {"sphere_pixels", f.sphere_pixels},
          {"shadow_bytes", r.shadow_bytes},
          {"ambient_bytes", r.ambient_bytes},
          {"bvh_bytes", r.bvh_bytes}};
}

nlohmann::json diff_json(const ImageDifference& d) {
  return {{"rmse", d.rmse}, {"psnr", std::isinf(d.psnr) ? nlohmann::json("inf") : nlohmann::json(d.psnr)},
          {"max_abs", d.max_abs}};
}

// Fraction of the pixels that differ by more than one 8-bit step in some channel.
double differing_pixels(const Image& a, const Image& b) {
  if (a.width() != b.width() || a.height() != b.height() || a.pixels().empty()) return kNaN;
  std::size_t n = 0;
  auto differs = [](float x, float y) { return std::abs(clamp(x, 0, 1) - clamp(y, 0, 1)) > 1.0f / 255.0f; };
  for (std::size_t i = 0; i < a.pixels().size(); ++i) {
    const Rgb& p = a.pixels()[i];
    const Rgb& q = b.pixels()[i];
    if (differs(p.r, q.r) || differs(p.g, q.g) || differs(p.b, q.b)) ++n;
  }
  return static_cast<double>(n) / static_cast<double>(a.pixels().size());
}

std::string load_average() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  in >> a >> b >> c;
  return a + " " + b + " " + c;
}

std::string diff_cell(const ImageDifference& d) { return fmt("%.4f", d.rmse) + " / " + fmt("%.1f", d.psnr); }

// Shadow disagreement: the visible points facing the light that the ISSM (t = 1 and t = 0) puts on the
// other side of the shadow boundary (light fraction 0.5) than one exact shadow ray does.
struct Disagreement {
  std::size_t points = 0;               // visible sphere points facing the light
  // index 0: the ISSM with t = 1 ring, index 1: with t = 0
  std::size_t missed[2] = {0, 0};       // lit by the ISSM, shadowed by the ray
  std::size_t spurious[2] = {0, 0};     // shadowed by the ISSM, lit by the ray
  double fraction(int i) const {
    return points ? static_cast<double>(missed[i] + spurious[i]) / static_cast<double>(points) : 0.0;
  }
};

Disagreement shadow_disagreement(const Scene& scene, const ParticleSet& set, int rings) {
  const Camera& cam = scene.camera;
  const SphereHits hits = splat_spheres(set, cam);
  const Light& light = scene.lights.at(0);
  // `set` as one segment of the frame's particle set: the scene's particle object 0
  const std::uint32_t offsets[] = {0, static_cast<std::uint32_t>(set.size())};
  const std::uint32_t objects[] = {0};
  const SurfaceInputs in{&scene, &cam, &set, offsets, objects, &hits, {}};
  VisibleSurfaces vs = visible_surfaces(in);
  std::vector<SurfacePoint> pts;
  pts.reserve(vs.points.size());
  for (const auto& p : vs.points) {
    Vec3 to_light;
    float distance;
    light.towards(p.position, to_light, distance);
    if (p.self != kNoSphere && dot(p.normal, to_light) > 0) pts.push_back(p);
  }
  // the spheres alone cast, for the map and for the exact rays alike
  const SphereBvh bvh(set);
  const std::vector<const MacrocellGrid*> no_grids(scene.volumes.size(), nullptr);
  ShadowCasters all(scene, no_grids);
  all.set_spheres(CastingSpheres{&set, &bvh, set.bounds()});
  const ShadowCasters spheres = all.restricted_to(kind_bit(ObjectKind::Spheres));
  ImplicitSphereShadowMap issm(IssmParams{static_cast<int>(param_integer(TechniqueFamily::Shadow, scene.shadows.params, "resolution")), rings, 0, 1, 10});
  issm.build(spheres, light);
  RayTracedShadows exact(0, 1);
  exact.build(spheres, light);
  std::vector<Rgb> ray(pts.size()), map1(pts.size()), map0(pts.size());
  parallel_for(pts.size(), [&](std::size_t b, std::size_t e) {
    const std::span<const SurfacePoint> p(pts.data() + b, e - b);
    exact.transmittance(p, std::span<Rgb>(ray.data() + b, e - b));
    issm.transmittance(p, std::span<Rgb>(map1.data() + b, e - b));
  }, 1024);
  issm.set_rings(0);
  parallel_for(pts.size(), [&](std::size_t b, std::size_t e) {
    issm.transmittance(std::span<const SurfacePoint>(pts.data() + b, e - b), std::span<Rgb>(map0.data() + b, e - b));
  }, 1024);
  Disagreement d;
  d.points = pts.size();
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const bool lit = ray[i].r >= 0.5f;  // grey: spheres pass no light
    for (int k = 0; k < 2; ++k) {
      const bool map_lit = (k == 0 ? map1[i] : map0[i]).r >= 0.5f;
      if (map_lit && !lit) ++d.missed[k];
      if (!map_lit && lit) ++d.spurious[k];
    }
  }
  return d;
}

struct Tables {
  std::ostringstream fps, frames, error, rasterizers;
};

void bench_dataset(const ParticleBenchOptions& o, const ParticleDataset& ds, Tables& tab, nlohmann::json& out) {
  const std::string name = ds.name;
  const std::string file = o.data_dir + "/" + ds.file;
  malloc_trim(0);  // what the previous data set freed, so that the peak below is this one's
  const bool rss_reset = reset_peak_rss();
  nlohmann::json j;
  j["file"] = file;
  j["assembly"] = ds.assembly;

  // 1. Load.
  std::fprintf(stderr, "bench particles %s: loading %s...\n", name.c_str(), file.c_str());
  Timer t_load;
  const Scene base = build_scene(particle_scene_json(file, ds.assembly, o.width, o.height), "");
  const double load_ms = t_load.elapsed_ms();
  const ParticleSet& set = *base.particles.at(0).set;
  const std::size_t spheres = set.size();
  const std::size_t particle_bytes = Renderer(base).particle_memory_bytes();
  const bool huge = spheres > o.huge_spheres;
  const int repeats = huge ? 1 : std::max(1, o.repeats);
  const int W = o.width, H = o.height;
  const std::string img = o.dir + "/" + name + "_";

  // The frame the ray-traced references and the error are measured at: reduced for large data sets.
  int rw = W, rh = H;
  if (spheres > o.full_reference_spheres && static_cast<std::size_t>(W) * H > o.reference_pixels) {
    const double f = std::sqrt(static_cast<double>(o.reference_pixels) / (static_cast<double>(W) * H));
    rw = std::max(16, static_cast<int>(W * f));
    rh = std::max(16, static_cast<int>(H * f));
  }
  const bool reduced = rw != W || rh != H;
  const bool references = !huge;
  // Full-size frames are kept only where the error is measured on them.
  auto keep_or_drop = [&](FrameRun& r) {
    if (reduced || !references) r.first.image = Image();
  };

  // 2. Frames at full size (after one unmeasured frame that faults in the memory and starts the threads)
  if (!huge) (void)Renderer(variant(base, "none", "none", W, H)).render();
  // and 3. both rasterizers: the LL frame with Embree rays instead of splatting; all interleaved.
  std::fprintf(stderr, "bench particles %s: LL, ISSM, ISSM + AO%s and LL with Embree at %s, interleaved...\n",
               name.c_str(), huge ? "" : ", AO", size_str(W, H).c_str());
  Timing t_ll(variant(base, "none", "none", W, H), false);
  Timing t_issm(variant(base, "issm", "none", W, H), true);
  Timing t_issm_ao(variant(base, "issm", "particle_ao", W, H), true);
  Timing t_ao(variant(base, "none", "particle_ao", W, H), false);
  Timing t_embree(variant(base, "none", "none", W, H, 1, SphereRasterizer::Embree), false);
  std::vector<Timing*> timings{&t_ll, &t_issm, &t_issm_ao, &t_embree};
  if (!huge) timings.push_back(&t_ao);
  run_interleaved(timings, repeats);
  FrameRun &ll = t_ll.run, &issm = t_issm.run, &issm_ao = t_issm_ao.run, &ao = t_ao.run, &embree = t_embree.run;
  const ImageDifference splat_vs_embree = compare_images(ll.first.image, embree.first.image);
  const double splat_vs_embree_pixels = differing_pixels(ll.first.image, embree.first.image);
  embree.first.image = Image();
  write_image(img + "ll.png", ll.first.image);
  write_image(img + "issm.png", issm.first.image);
  write_image(img + "issm_ao.png", issm_ao.first.image);
  if (!huge) write_image(img + "ao.png", ao.first.image);
  ao.first.image = Image();
  keep_or_drop(ll);
  keep_or_drop(issm);
  keep_or_drop(issm_ao);

  // 4. References and error.
  FrameRun rt, rt_ao;
  ImageDifference e_ll, e_issm, e_issm0, e_issm_ao;
  Disagreement dis;
  if (references) {
    std::fprintf(stderr, "bench particles %s: ray-traced references at %s...\n", name.c_str(), size_str(rw, rh).c_str());
    rt = run_frames(variant(base, "ray_traced", "none", rw, rh), 0, false);
    write_image(img + "ray_traced.png", rt.first.image);
    rt_ao = run_frames(variant(base, "ray_traced", "ray_traced_ao", rw, rh), 0, false);
    write_image(img + "ray_traced_ao.png", rt_ao.first.image);
    const std::string suffix = reduced ? "_" + std::to_string(rw) + "x" + std::to_string(rh) + ".png" : ".png";
    auto at_reference = [&](const FrameRun& full, const std::string& config, const std::string& shadows,
                            const std::string& ambient, int rings = 1) {
      if (!reduced && rings == 1) return full.first.image;
      Image image = Renderer(variant(base, shadows, ambient, rw, rh, rings)).render().image;
      write_image(img + config + suffix, image);
      return image;
    };
    e_ll = compare_images(at_reference(ll, "ll", "none", "none"), rt.first.image);
    e_issm = compare_images(at_reference(issm, "issm", "issm", "none"), rt.first.image);
    e_issm0 = compare_images(at_reference(issm, "issm_t0", "issm", "none", 0), rt.first.image);
    e_issm_ao = compare_images(at_reference(issm_ao, "issm_ao", "issm", "particle_ao"), rt_ao.first.image);
    std::fprintf(stderr, "bench particles %s: shadow disagreement...\n", name.c_str());
    dis = shadow_disagreement(variant(base, "issm", "none", rw, rh), set, 1);
  }
  const std::size_t peak_rss = proc_status_kib("VmHWM") * 1024;

  // Markdown rows.
  auto fps = [](double ms) { return std::isnan(ms) ? std::string("—") : fmt("%.1f", 1000.0 / ms); };
  const double r_issm = issm.cached_ms / ll.cached_ms, r_issm_ao = issm_ao.cached_ms / ll.cached_ms;
  const double r_issm_moving = issm.moving_ms / ll.cached_ms;
  const std::string label = name + (huge ? " ¹" : "");
  tab.fps << "| " << label << " | " << spheres << " | " << fps(ll.cached_ms) << " | " << fps(issm.cached_ms) << " | "
          << fps(issm_ao.cached_ms) << " | " << fmt("%.2f×", r_issm) << (r_issm <= 1.2 ? "" : " ✗") << " | "
          << fmt("%.2f×", r_issm_ao) << " | " << fps(issm.moving_ms) << " | " << fmt("%.2f×", r_issm_moving) << " | "
          << fps(issm_ao.moving_ms) << " |\n";
  auto frame_row = [&](const std::string& config, const FrameRun& r, int w, int h, bool cached) {
    const FrameResult& f = r.first;
    tab.frames << "| " << label << " | " << config << " | " << size_str(w, h) << " | " << fmt("%.1f", f.total_ms) << " | "
               << (f.bvh_ms > 0 ? fmt("%.1f", f.bvh_ms) : "—") << " | "
               << (f.ambient_ms > 0 ? fmt("%.1f", f.ambient_ms) : "—")
               << " | " << fmt("%.1f", f.build_ms) << " | " << (cached ? fmt("%.1f", r.cached_ms) : "—") << " | "
               << (cached ? fmt("%.1f", r.cached_hits_ms) : "—") << " | " << fmt("%.1f", r.moving_ms) << " | "
               << (cached ? fmt("%.2f", r.cached_ms / ll.cached_ms) : "—") << " |\n";
  };
  frame_row("LL", ll, W, H, true);
  frame_row("ISSM", issm, W, H, true);
  frame_row("ISSM + AO", issm_ao, W, H, true);
  if (!huge) {
    frame_row("AO", ao, W, H, true);
    frame_row("ray_traced", rt, rw, rh, false);
    frame_row("ray_traced + ray_traced_ao (64 rays)", rt_ao, rw, rh, false);
  }
  auto pct = [](double v) { return fmt("%.2f %%", 100.0 * v); };
  const double missed = static_cast<double>(dis.missed[0]) / static_cast<double>(std::max<std::size_t>(1, dis.points));
  tab.error << "| " << label << " | " << (huge ? "—" : size_str(rw, rh)) << " | " << (huge ? "—" : diff_cell(e_ll)) << " | "
            << (huge ? "—" : diff_cell(e_issm)) << " | " << (huge ? "—" : diff_cell(e_issm0)) << " | "
            << (huge ? "—" : diff_cell(e_issm_ao)) << " | "
            << (huge ? "—"
                     : pct(dis.fraction(0)) + " (" + pct(missed) + " missed) / " + pct(dis.fraction(1)))
            << " | " << fmt("%.0f", load_ms) << " | " << mib(particle_bytes) << " | " << mib(issm.shadow_bytes) << " | "
            << mib(issm_ao.ambient_bytes) << " | " << mib(embree.bvh_bytes) << " | " << mib(peak_rss)
            << (rss_reset ? "" : " ²") << " |\n";
  tab.rasterizers << "| " << label << " | " << size_str(W, H) << " | " << ll.first.sphere_pixels << " | "
                  << fmt("%.1f", ll.cached_hits_ms) << " | " << fmt("%.1f", embree.cached_hits_ms) << " | "
                  << fmt("%.1f", embree.first.bvh_ms) << " | " << mib(embree.bvh_bytes) << " | "
                  << fmt("%.3f %%", 100.0 * splat_vs_embree_pixels) << " | " << fmt("%.3f", splat_vs_embree.max_abs) << " |\n";

  // JSON.
  j["spheres"] = spheres;
  j["load_ms"] = load_ms;
  j["particle_bytes"] = particle_bytes;
  j["peak_rss_bytes"] = peak_rss;
  j["peak_rss_is_per_dataset"] = rss_reset;
  j["frames_per_median"] = repeats;
  j["configs"]["ll"] = run_json(ll, W, H);
  j["configs"]["issm"] = run_json(issm, W, H);
  j["configs"]["issm_ao"] = run_json(issm_ao, W, H);
  j["ratios"] = {{"issm_over_ll", r_issm}, {"issm_ao_over_ll", r_issm_ao}, {"issm_moving_light_over_ll", r_issm_moving},
                 {"issm_ao_moving_light_over_ll", issm_ao.moving_ms / ll.cached_ms}};
  j["rasterizers"] = {{"splat_hits_ms", ll.cached_hits_ms}, {"embree_hits_ms", embree.cached_hits_ms},
                      {"embree_bvh_ms", embree.first.bvh_ms}, {"embree_bvh_bytes", embree.bvh_bytes},
                      {"splat_vs_embree", diff_json(splat_vs_embree)},
                      {"splat_vs_embree_differing_pixels", splat_vs_embree_pixels}};
  if (!huge) {
    j["configs"]["ao"] = run_json(ao, W, H);
    j["configs"]["ray_traced"] = run_json(rt, rw, rh);
    j["configs"]["ray_traced_ao"] = run_json(rt_ao, rw, rh);
    j["error"] = {{"width", rw},
                  {"height", rh},
                  {"ll_vs_ray_traced", diff_json(e_ll)},
                  {"issm_vs_ray_traced", diff_json(e_issm)},
                  {"issm_t0_vs_ray_traced", diff_json(e_issm0)},
                  {"issm_ao_vs_ray_traced_ao", diff_json(e_issm_ao)},
                  {"shadow_disagreement",
                   {{"points_facing_light", dis.points},
                    {"t1", {{"fraction", dis.fraction(0)}, {"missed", dis.missed[0]}, {"spurious", dis.spurious[0]}}},
                    {"t0", {{"fraction", dis.fraction(1)}, {"missed", dis.missed[1]}, {"spurious", dis.spurious[1]}}}}}};
  }
  out["datasets"][name] = j;
}

}  // namespace

void bench_particles(const ParticleBenchOptions& o, std::ostringstream& md, nlohmann::json& out) {
  std::vector<const ParticleDataset*> sets;
  for (const auto& d : o.datasets) {
    const ParticleDataset& ds = find_dataset(d);
    const std::string file = o.data_dir + "/" + ds.file;
    if (!std::filesystem::exists(file)) throw Error("--particle-datasets " + d + ": " + file + " not found (see --data-dir)");
    sets.push_back(&ds);
  }
  Timer total;
  const std::string load_before = load_average();
  Tables tab;
  for (const ParticleDataset* ds : sets) bench_dataset(o, *ds, tab, out);
  out["width"] = o.width;
  out["height"] = o.height;
  out["repeats"] = o.repeats;
  out["wall_s"] = total.elapsed_ms() / 1000.0;

  md << "\n## Implicit sphere shadow maps (paper 003, Fig. 8) on this machine\n\n"
     << "Frames of " << size_str(o.width, o.height) << ", one directional light, ISSM 512² with t = 1 ring, "
     << "particle_ao with 16 directions (reach 0.7), colour by chain. Frame times are medians of " << o.repeats
     << " frames after a first (warm-up) frame, the configurations interleaved frame by frame; “cached”: static "
        "light and camera, shadows and AO reused from the first frame; “light moved”: the light turns by 1° every "
        "frame, so the ISSM is rebuilt. "
     << "The allocator keeps freed memory between frames (main.cpp: glibc mmap threshold 1 GiB, no trimming): "
        "otherwise every frame page-faults its ~100 MB of buffers anew, which here costs more than the shading. "
     << "The paper's bar: ISSM at ≥ 80 % of the LL frame rate (≤ 1.25× its time); ours ≤ 1.2× (✗ marks a miss). "
        "Suite wall time "
     << fmt("%.0f", total.elapsed_ms() / 1000.0) << " s; load average " << load_before << " before, "
     << load_average() << " after (other processes on the machine disturb the timings).\n\n"
     << "**Frame rates, fps (paper Fig. 8)**\n\n"
     << "| data set | spheres | LL | ISSM | ISSM + AO | ISSM / LL time | (ISSM + AO) / LL time | ISSM, light moved | "
        "ISSM light moved / LL | ISSM + AO, light moved |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n"
     << tab.fps.str()
     << "\n**Frame times, ms**: first frame (with its BVH, AO and shadow builds), cached frame and its "
        "visible-sphere pass (hits), frame with a moving light. The ray-traced references are single frames.\n\n"
     << "| data set | configuration | frame | first frame | BVH | AO build | shadow build | cached | hits | light moved | "
        "× LL |\n|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|\n"
     << tab.frames.str()
     << "\n**Error and memory.** RMSE / PSNR dB against the ray-traced references at the frame given (reduced "
        "above "
     << o.full_reference_spheres << " spheres); ISSM and ISSM t = 0 against ray_traced shadows, ISSM + AO against "
        "ray_traced + ray_traced_ao (64 rays), LL against ray_traced for scale. Shadow disagreement: visible sphere "
        "points facing the light that the ISSM puts on the other side of the shadow boundary than one exact shadow "
        "ray (missed: lit by the ISSM, shadowed by the ray). Peak RSS: VmHWM of the process during the data set, "
        "including the bench's own frames (26 MiB per 1920×1200 float image).\n\n"
     << "| data set | error frame | LL vs RT | ISSM vs RT | ISSM t = 0 vs RT | ISSM + AO vs RT + RTAO | shadow "
        "disagreement t = 1 / t = 0 | load ms | particles MiB | ISSM MiB | AO MiB | Embree BVH MiB | peak RSS MiB "
        "|\n|---|---|---|---|---|---|---|---:|---:|---:|---:|---:|---:|\n"
     << tab.error.str()
     << "\n**Sphere rasterizers** (the LL frame): each pixel's nearest sphere by tile-binned splatting and by "
        "one Embree ray per pixel (cached-frame median), the Embree BVH build, and how the two frames differ: "
        "the share of pixels differing by more than one 8-bit step and the largest "
        "difference (both find the nearest sphere exactly; they may differ where two spheres are equally near).\n\n"
     << "| data set | frame | sphere pixels | splat ms | Embree ms | Embree BVH build ms | BVH MiB | pixels differing "
        "| max difference |\n|---|---|---:|---:|---:|---:|---:|---:|---:|\n"
     << tab.rasterizers.str();
  bool any_huge = false;
  for (const ParticleDataset* ds : sets) any_huge |= out["datasets"][ds->name]["spheres"].get<std::size_t>() > o.huge_spheres;
  if (any_huge)
    md << "\n¹ Above " << o.huge_spheres << " spheres: LL, ISSM and ISSM + AO only, one frame each, no references.\n";
  if (!reset_peak_rss())
    md << "\n² The peak RSS could not be reset per data set: it is the process's peak so far.\n";
}

}  // namespace penumbra::cli
