// `penumbra bench --suite extinction`: paper 001's result tables on this machine. SAT construction time
// per light-cache size (§4), ambient occlusion by 3 / 7 / 11 cuboid shells against sampling the radius-7
// ball cell by cell (Table 2), soft shadows by 20 and 50 cone samples against one hard shadow ray per
// cell (Table 3), and frames per second with and without illumination, with a static and a moving
// light (Table 1) — plus what the paper lacks: memory, and error (RMSE, PSNR) against the references
// (ray_traced shadows, sampled_ao).
#include <cstdio>
#include <filesystem>
#include <limits>
#include <sstream>

#include "bench_extinction.h"
#include "bench_format.h"
#include "penumbra/core/error.h"
#include "penumbra/core/image_io.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene_io/demo_scenes.h"
#include "penumbra/scene_io/scene_file.h"
#include "penumbra/registry/technique_catalog.h"
#include "penumbra/shadows/sat_cone.h"
#include "penumbra/shadows/volume_ambient_occlusion.h"

namespace penumbra::cli {
namespace {

// Fastest of `repeats` runs of f(), in ms.
template <class F>
double fastest_ms(int repeats, F&& f) {
  double best = std::numeric_limits<double>::infinity();
  for (int r = 0; r < std::max(1, repeats); ++r) {
    Timer t;
    f();
    best = std::min(best, t.elapsed_ms());
  }
  return best;
}

// A scene, its medium and a SAT at one resolution, for timing the cache builds alone.
struct CacheBench {
  CacheBench(const Scene& s, int resolution) : scene(s) {
    const VolumeObject& v = *scene.visible_volume();
    grid = std::make_unique<MacrocellGrid>(*v.volume);
    // the visible volume casts with its macrocells; the scene's other volumes are not drawn
    grids.assign(scene.volumes.size(), nullptr);
    grids.at(static_cast<std::size_t>(&v - scene.volumes.data())) = grid.get();
    medium = std::make_unique<ShadowCasters>(scene, grids);
    sat = std::make_unique<ExtinctionSat>(*v.volume, v.shadow_tf(), v.compositing, v.reference_step(), resolution, false);
    medium->attach_extinction_sat(sat.get());
  }
  const Scene& scene;
  std::unique_ptr<MacrocellGrid> grid;
  std::vector<const MacrocellGrid*> grids;  // per scene volume
  std::unique_ptr<ShadowCasters> medium;
  std::unique_ptr<ExtinctionSat> sat;
};

// What Table 3's "1 shadow ray" column times: the light cache filled by one exact shadow ray per cell.
void hard_ray_cache(const ShadowCasters& medium, const ExtinctionSat& sat, const Light& light) {
  const auto& d = sat.dims();
  std::vector<float> cache(sat.cell_count());
  parallel_for(static_cast<std::size_t>(d[2]) * d[1], [&](std::size_t r0, std::size_t r1) {
    for (std::size_t r = r0; r < r1; ++r) {
      const int j = static_cast<int>(r % d[1]), k = static_cast<int>(r / d[1]);
      for (int i = 0; i < d[0]; ++i) {
        if (!sat.near_extinction(i, j, k)) continue;
        const Vec3 p = sat.cell_center(i, j, k);
        Vec3 to_light;
        float distance;
        light.towards(p, to_light, distance);
        cache[sat.cell_index(i, j, k)] = medium.transmittance(Ray{p, to_light}, 0, distance).g;
      }
    }
  });
}

void cache_tables(const ExtinctionBenchOptions& o, const std::string& name, const Scene& scene, std::ostringstream& md,
                  nlohmann::json& out) {
  md << "\n### " << name << ": light-cache builds (ms)\n\n"
     << "| cache size | SAT | AO 3 shells | AO 7 shells | AO 11 shells | AO sampled r = 7 | shadows 50 samples | "
        "shadows 20 samples | 1 shadow ray | SAT memory MiB |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
  const Light light = scene.lights.at(0);
  for (const int n : o.cache_sizes) {
    std::fprintf(stderr, "bench extinction %s: cache %d³...\n", name.c_str(), n);
    const VolumeObject& v = *scene.visible_volume();
    const double sat_ms = fastest_ms(o.repeats, [&] {
      ExtinctionSat s(*v.volume, v.shadow_tf(), v.compositing, v.reference_step(), n, false);
    });
    CacheBench b(scene, n);
    const int longest = std::max(b.sat->dims()[0], std::max(b.sat->dims()[1], b.sat->dims()[2]));
    AmbientSettings a;
    a.params.set("radius", 7.0 / static_cast<double>(longest));  // the paper's radius of 7 cells for every column
    std::vector<double> ao_ms;
    for (const int shells : {3, 7, 11}) {
      a.params.set("shells", shells);
      ao_ms.push_back(fastest_ms(o.repeats, [&] { SatShellsAmbient(a.params).build(*b.medium); }));
    }
    const bool sample = n <= o.max_sampled_size;
    const double sampled_ms = sample ? fastest_ms(1, [&] { SampledAmbientOcclusion(a.params).build(*b.medium); }) : -1;
    std::vector<double> shadow_ms;
    for (const float samples : {50.0f, 20.0f}) {
      ShadowSettings s = scene.shadows;
      s.params.set("cone_samples", static_cast<double>(samples));
      shadow_ms.push_back(fastest_ms(o.repeats, [&] { SatConeShadows(s.params).build(*b.medium, light); }));
    }
    const double ray_ms = fastest_ms(o.repeats, [&] { hard_ray_cache(*b.medium, *b.sat, light); });
    md << "| " << n << "³ (" << b.sat->dims()[0] << "×" << b.sat->dims()[1] << "×" << b.sat->dims()[2] << ") | "
       << fmt("%.1f", sat_ms) << " | " << fmt("%.1f", ao_ms[0]) << " | " << fmt("%.1f", ao_ms[1]) << " | "
       << fmt("%.1f", ao_ms[2]) << " | " << (sample ? fmt("%.0f", sampled_ms) : std::string("—")) << " | "
       << fmt("%.1f", shadow_ms[0]) << " | " << fmt("%.1f", shadow_ms[1]) << " | " << fmt("%.1f", ray_ms) << " | "
       << fmt("%.1f", static_cast<double>(b.sat->memory_bytes()) / 1048576.0) << " |\n";
    out["caches"][name].push_back({{"size", n}, {"sat_ms", sat_ms}, {"ao_3_ms", ao_ms[0]}, {"ao_7_ms", ao_ms[1]},
                                   {"ao_11_ms", ao_ms[2]}, {"ao_sampled_r7_ms", sampled_ms},
                                   {"shadows_50_ms", shadow_ms[0]}, {"shadows_20_ms", shadow_ms[1]},
                                   {"shadow_ray_ms", ray_ms}, {"sat_bytes", b.sat->memory_bytes()}});
  }
  // Accuracy of the cuboid cone against the densely sampled cone (the same model, exact rays) at the
  // filled cells of a small cache (64³).
  {
    CacheBench b(scene, o.accuracy_cache);
    ShadowSettings s = scene.shadows;
    SatConeShadows cone(s.params);
    cone.build(*b.medium, light);
    const auto& d = b.sat->dims();
    constexpr int kRays = 32;
    std::vector<double> err2(static_cast<std::size_t>(d[2]), 0.0), errmax(static_cast<std::size_t>(d[2]), 0.0);
    std::vector<std::size_t> cells(static_cast<std::size_t>(d[2]), 0);
    Timer t;
    parallel_for(static_cast<std::size_t>(d[2]), [&](std::size_t k0, std::size_t k1) {
      for (std::size_t k = k0; k < k1; ++k)
        for (int j = 0; j < d[1]; ++j)
          for (int i = 0; i < d[0]; ++i) {
            if (!b.sat->near_extinction(i, j, static_cast<int>(k))) continue;
            const Vec3 p = b.sat->cell_center(i, j, static_cast<int>(k));
            const double e = cone.attenuation(p) - sampled_cone_transmittance(*b.medium, light, p, cone.sampling().half_angle, kRays);
            err2[k] += e * e;
            errmax[k] = std::max(errmax[k], std::abs(e));
            ++cells[k];
          }
    });
    const double ms = t.elapsed_ms();
    double sum2 = 0, emax = 0;
    std::size_t n = 0;
    for (std::size_t k = 0; k < err2.size(); ++k) {
      sum2 += err2[k];
      emax = std::max(emax, errmax[k]);
      n += cells[k];
    }
    const double rmse = n ? std::sqrt(sum2 / static_cast<double>(n)) : 0;
    md << "\nAt " << o.accuracy_cache << "³, " << n << " filled cells: sat_cone (" << param_number(TechniqueFamily::Shadow, s.params, "cone_angle") << "°, " << param_number(TechniqueFamily::Shadow, s.params, "cone_samples")
       << " samples) against the densely sampled cone (" << kRays << " exact rays per cell, " << fmt("%.0f", ms)
       << " ms): transmittance RMSE " << fmt("%.4f", rmse) << ", largest difference " << fmt("%.3f", emax) << ".\n";
    out["cone_accuracy"][name] = {{"cells", n}, {"rays", kRays}, {"sampled_cone_ms", ms}, {"rmse", rmse}, {"max", emax}};
  }
  md << "\nSampled AO beyond " << o.max_sampled_size << "³ is left out (—): it grows with the cells times the "
     << "1,436 cells of the ball and takes minutes there. Light: " << to_string(light.type) << ".\n";
}

struct FrameRow {
  std::string label;
  double ms = 0;
  std::vector<std::string> rebuilt;
};

void frame_table(const ExtinctionBenchOptions& o, const std::string& name, const nlohmann::json& scene_json,
                 std::ostringstream& md, nlohmann::json& out) {
  auto scene_with = [&](const std::string& shadows, const std::string& ambient, bool second_light = false) {
    nlohmann::json j = scene_json;
    apply_override(j, "shadows.technique", shadows);
    apply_override(j, "ambient.technique", ambient);
    // a second, static light from the other side (the paper's Cornell box and skull have fixed lights)
    if (second_light)
      j["lights"].push_back({{"type", "directional"}, {"direction", {-0.5, 0.4, -0.75}}, {"intensity", 0.5}});
    return build_scene(j, "");
  };
  std::fprintf(stderr, "bench extinction %s: frames...\n", name.c_str());
  // A cached frame: what a camera move costs once everything is built (fastest of the repeats).
  // `bytes`: what the frame's illumination holds (SAT, ambient and shadow caches, the packed light cache).
  auto cached_frame = [&](const Scene& s, Image* image, std::size_t* bytes = nullptr) {
    Renderer r(s);
    const FrameResult first = r.render();
    double best = std::numeric_limits<double>::infinity();
    for (int i = 0; i < o.repeats; ++i) {
      const Camera cam = s.camera.orbited(0.02f * static_cast<float>(i + 1));
      const FrameResult f = r.render(cam, s.lights);
      if (!f.rebuilt.empty()) throw Error("bench: a camera move rebuilt " + f.rebuilt.front());
      best = std::min(best, f.total_ms);
    }
    if (image) *image = first.image;
    if (bytes)
      *bytes = r.sat_memory_bytes() + r.ambient_memory_bytes() + r.shadow_memory_bytes() + r.light_cache_memory_bytes();
    return std::make_pair(first, best);
  };
  const Scene plain = scene_with("none", "none");
  const Scene ao = scene_with("none", "sat_shells");
  const Scene lit = scene_with("sat_cone", "sat_shells");
  const Scene shadows_only = scene_with("sat_cone", "none");
  Image img_plain, img_ao, img_lit, img_shadow;
  const auto [f_plain, ms_plain] = cached_frame(plain, &img_plain);
  std::size_t bytes_ao = 0, bytes_lit = 0, bytes_shadow = 0;
  const auto [f_ao, ms_ao] = cached_frame(ao, &img_ao, &bytes_ao);
  const auto [f_lit, ms_lit] = cached_frame(lit, &img_lit, &bytes_lit);
  const auto [f_shadow, ms_shadow] = cached_frame(shadows_only, &img_shadow, &bytes_shadow);
  // Two static lights and AO: every term from the packed light cache, one fetch per sample (§3)
  const auto [f_plain2, ms_plain2] = cached_frame(scene_with("none", "none", true), nullptr);
  const auto [f_lit2, ms_lit2] = cached_frame(scene_with("sat_cone", "sat_shells", true), nullptr);
  (void)f_plain2;
  (void)f_lit2;
  (void)f_plain;
  (void)f_shadow;
  // A moving light: the shadows are rebuilt every frame (Algorithm 1, line 14).
  double ms_moving = 0;
  {
    Renderer r(lit);
    (void)r.render();
    const int frames = std::max(2, o.repeats);
    for (int i = 1; i <= frames; ++i) {
      std::vector<Light> lights = lit.lights;
      Light& l = lights[0];
      const float a = 0.3f * static_cast<float>(i);
      const Vec3 c = lit.caster_bounds().center();
      const Vec3 d = l.position - c;
      l.position = c + Vec3{d.x * std::cos(a) - d.z * std::sin(a), d.y, d.x * std::sin(a) + d.z * std::cos(a)};
      l.direction = normalize(Vec3{l.direction.x * std::cos(a) - l.direction.z * std::sin(a), l.direction.y,
                                   l.direction.x * std::sin(a) + l.direction.z * std::cos(a)});
      ms_moving += r.render(lit.camera, lights).total_ms;
    }
    ms_moving /= frames;
  }
  // References: exact shadow rays (the cone's hard limit) and the sampled neighbourhood.
  const Scene ref_ao = scene_with("none", "sampled_ao");
  const Scene ref_shadow = scene_with("ray_traced", "none");
  const Scene ref_both = scene_with("ray_traced", "sampled_ao");
  Timer t_ref;
  const Image img_ref_both = Renderer(ref_both).render().image;
  const double ms_ref = t_ref.elapsed_ms();
  const Image img_ref_ao = Renderer(ref_ao).render().image;
  const Image img_ref_shadow = Renderer(ref_shadow).render().image;
  nlohmann::json hard_json = scene_json;
  apply_override(hard_json, "shadows.cone_angle", "0");
  apply_override(hard_json, "shadows.technique", "sat_cone");
  const Image img_hard = Renderer(build_scene(hard_json, "")).render().image;
  for (const auto& [file, img] : std::vector<std::pair<std::string, const Image*>>{
           {"plain", &img_plain}, {"sat_shells", &img_ao}, {"sat_cone_sat_shells", &img_lit},
           {"sat_cone", &img_shadow}, {"sampled_ao", &img_ref_ao}, {"ray_traced", &img_ref_shadow},
           {"ray_traced_sampled_ao", &img_ref_both}, {"sat_cone_0deg", &img_hard}})
    write_image(o.dir + "/extinction_" + name + "_" + file + ".png", *img);

  const ImageDifference e_ao = compare_images(img_ao, img_ref_ao);
  const ImageDifference e_shadow = compare_images(img_shadow, img_ref_shadow);
  const ImageDifference e_hard = compare_images(img_hard, img_ref_shadow);
  const ImageDifference e_both = compare_images(img_lit, img_ref_both);
  const ImageDifference e_plain = compare_images(img_plain, img_ref_shadow);
  auto fps = [](double ms) { return fmt("%.1f", 1000.0 / ms); };
  md << "\n### " << name << ": frames at " << o.size << "² (paper Table 1)\n\n"
     << "Extinction compositing; light cache " << lit.light_cache.resolution << "³, " << param_integer(TechniqueFamily::Ambient, lit.ambient.params, "shells")
     << " shells, radius " << param_number(TechniqueFamily::Ambient, lit.ambient.params, "radius") << ", cone " << param_number(TechniqueFamily::Shadow, lit.shadows.params, "cone_angle") << "°, "
     << param_number(TechniqueFamily::Shadow, lit.shadows.params, "cone_samples") << " samples. Build times of the first frame: SAT " << fmt("%.1f", f_lit.sat_ms)
     << " ms, AO " << fmt("%.1f", f_lit.ambient_ms) << " ms, shadows " << fmt("%.1f", f_lit.build_ms) << " ms.\n\n"
     << "| frame | ms | fps | × plain | error vs reference: RMSE / PSNR dB |\n|---|---:|---:|---:|---|\n"
     << "| no illumination (local Blinn–Phong) | " << fmt("%.1f", ms_plain) << " | " << fps(ms_plain) << " | 1.00 | "
     << fmt("%.4f", e_plain.rmse) << " / " << fmt("%.1f", e_plain.psnr) << " (vs ray_traced) |\n"
     << "| sat_shells AO, cached | " << fmt("%.1f", ms_ao) << " | " << fps(ms_ao) << " | " << fmt("%.2f", ms_ao / ms_plain)
     << " | " << fmt("%.4f", e_ao.rmse) << " / " << fmt("%.1f", e_ao.psnr) << " (vs sampled_ao) |\n"
     << "| sat_cone shadows, static light, cached | " << fmt("%.1f", ms_shadow) << " | " << fps(ms_shadow) << " | "
     << fmt("%.2f", ms_shadow / ms_plain) << " | " << fmt("%.4f", e_shadow.rmse) << " / " << fmt("%.1f", e_shadow.psnr)
     << " (vs ray_traced; 0° cone: " << fmt("%.1f", e_hard.psnr) << " dB) |\n"
     << "| sat_cone + sat_shells, static light, cached | " << fmt("%.1f", ms_lit) << " | " << fps(ms_lit) << " | "
     << fmt("%.2f", ms_lit / ms_plain) << " | " << fmt("%.4f", e_both.rmse) << " / " << fmt("%.1f", e_both.psnr)
     << " (vs ray_traced + sampled_ao) |\n"
     << "| no illumination, two lights | " << fmt("%.1f", ms_plain2) << " | " << fps(ms_plain2) << " | "
     << fmt("%.2f", ms_plain2 / ms_plain) << " | |\n"
     << "| sat_cone (two static lights) + sat_shells, cached | " << fmt("%.1f", ms_lit2) << " | " << fps(ms_lit2) << " | "
     << fmt("%.2f", ms_lit2 / ms_plain) << " (" << fmt("%.2f", ms_lit2 / ms_plain2) << "× two lights without illumination) | |\n"
     << "| sat_cone + sat_shells, moving light (shadows rebuilt) | " << fmt("%.1f", ms_moving) << " | " << fps(ms_moving)
     << " | " << fmt("%.2f", ms_moving / ms_plain) << " | |\n"
     << "| reference: ray_traced + sampled_ao | " << fmt("%.0f", ms_ref) << " | " << fps(ms_ref) << " | "
     << fmt("%.1f", ms_ref / ms_plain) << " | |\n";
  out["frames"][name] = {{"plain_ms", ms_plain},
                         {"ao_ms", ms_ao},
                         {"shadows_ms", ms_shadow},
                         {"lit_ms", ms_lit},
                         {"plain_two_lights_ms", ms_plain2},
                         {"lit_two_lights_ms", ms_lit2},
                         {"moving_light_ms", ms_moving},
                         {"reference_ms", ms_ref},
                         {"memory_bytes", {{"ao", bytes_ao}, {"shadows", bytes_shadow}, {"lit", bytes_lit}}},
                         {"first_frame", {{"sat_ms", f_lit.sat_ms}, {"ambient_ms", f_lit.ambient_ms}, {"shadows_ms", f_lit.build_ms}}},
                         {"psnr", {{"ao_vs_sampled", e_ao.psnr}, {"cone_vs_ray", e_shadow.psnr}, {"cone0_vs_ray", e_hard.psnr},
                                   {"lit_vs_reference", e_both.psnr}, {"plain_vs_ray", e_plain.psnr}}},
                         {"rmse", {{"ao_vs_sampled", e_ao.rmse}, {"cone_vs_ray", e_shadow.rmse}, {"cone0_vs_ray", e_hard.rmse},
                                   {"lit_vs_reference", e_both.rmse}}}};
}

nlohmann::json extinction_scene(nlohmann::json j, int size, int cache) {
  j["volumes"][0]["compositing"] = "extinction";
  j["planes"] = nlohmann::json::array();  // the paper's Table 1 renders the volume alone
  j["camera"]["width"] = size;
  j["camera"]["height"] = size;
  j["shadows"] = {{"technique", "none"}};
  if (cache > 0) j["light_cache"]["resolution"] = cache;
  return j;
}

}  // namespace

void bench_extinction(const ExtinctionBenchOptions& o, std::ostringstream& md, nlohmann::json& out) {
  md << "\n## Extinction-based illumination (paper 001) on this machine\n";
  for (const auto& d : o.datasets) {
    nlohmann::json scene;
    if (d == "procedural") {
      scene = test_spheres_scene(o.procedural_size);
    } else if (d == "cranium" || d == "chest") {
      const std::string file = o.data_dir + "/" + d + "_ct.nrrd";
      if (!std::filesystem::exists(file)) throw Error("--datasets " + d + ": " + file + " not found (see --data-dir)");
      scene = d == "cranium" ? cranium_scene(file) : chest_scene(file);
    } else {
      throw Error("--datasets: unknown data set '" + d + "' for the extinction suite (expected procedural, cranium or chest)");
    }
    scene = extinction_scene(scene, o.size, o.frame_cache);
    cache_tables(o, d, build_scene(scene, ""), md, out);
    frame_table(o, d, scene, md, out);
  }
}

}  // namespace penumbra::cli
