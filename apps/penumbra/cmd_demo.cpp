// `penumbra demo [-o DIR]`: renders the built-in test-spheres scene (and the head CT when
// ../shared/data is there) with every shadow technique, writes one PNG per technique and a side-by-side
// comparison (shadow_map | deep_shadow_map | cssm | ray_traced), and prints time, memory and error
// against the exact ray-traced shadows. Then the same for spheres (random spheres over a floor, and
// 1AON when it is there): local lighting | ISSM | ISSM + particle AO | ray-traced shadows + AO. Then a
// point-based isosurface of the procedural ct-body CT: points | points + light-pass shadows |
// marching-cubes mesh | ray-cast isosurface with exact shadow rays. Then two mixed scenes (a CT with
// metal implants; GroEL in its density map with an isosurface and a floor) with every map technique
// against ray_traced. `--quick` renders every scene
// test-sized (64² images, 128² maps, small volumes): a smoke test of the same code in seconds.
#include <cstdio>
#include <filesystem>

#include "commands.h"
#include "penumbra/core/error.h"
#include "penumbra/core/image_io.h"
#include "penumbra/core/parallel.h"
#include "penumbra/core/timer.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene_io/scene_file.h"
#include "penumbra/scene_io/demo_scenes.h"
#include "technique_runs.h"

namespace penumbra::cli {
namespace {

// The scene with its image resized (quick mode).
nlohmann::json sized(nlohmann::json scene, int width, int height) {
  scene["camera"]["width"] = width;
  scene["camera"]["height"] = height;
  return scene;
}

void demo_scene(const std::string& name, const nlohmann::json& scene, const std::string& dir, int resolution) {
  std::printf("\n%s (shadow maps %d², image %dx%d)\n", name.c_str(), resolution, scene["camera"].value("width", 512),
              scene["camera"].value("height", 512));
  std::printf("| technique       | build ms | render ms | shadow memory | RMSE vs ray_traced | PSNR dB |\n");
  std::printf("|-----------------|---------:|----------:|--------------:|-------------------:|--------:|\n");
  const TechniqueRun reference = run_technique(scene, "ray_traced", resolution, {}, 1);
  std::vector<TechniqueRun> runs;
  for (const char* t : {"none", "shadow_map", "deep_shadow_map", "cssm"}) runs.push_back(run_technique(scene, t, resolution, {}, 1));
  runs.push_back(reference);
  for (auto& r : runs) {
    const ImageDifference d = compare_images(r.image, reference.image);
    r.rmse = d.rmse;
    r.psnr = d.psnr;
    write_image(dir + "/" + name + "_" + r.technique + ".png", r.image);
    std::printf("| %-15s | %8.1f | %9.1f | %10.2f MB | %18.4f | %7.2f |\n", r.technique.c_str(), r.build_ms, r.render_ms,
                static_cast<double>(r.memory_bytes) / 1048576.0, r.rmse, r.psnr);
  }
  write_image(dir + "/" + name + "_comparison.png", montage({&runs[1].image, &runs[2].image, &runs[3].image, &runs[4].image}));
  std::printf("wrote %s/%s_*.png and %s_comparison.png (shadow_map | deep_shadow_map | cssm | ray_traced)\n", dir.c_str(),
              name.c_str(), name.c_str());
}

// One particle scene with local lighting, ISSM, ISSM + particle AO and the ray-traced references; the
// error of each against ray-traced shadows + ray-traced AO (and of ISSM against ray-traced shadows).
void demo_particles(const std::string& name, const nlohmann::json& scene_json, const std::string& dir) {
  struct Config {
    const char* label;
    const char* shadows;
    const char* ambient;
  };
  const Config configs[] = {{"local lighting", "none", "none"}, {"issm", "issm", "none"}, {"issm + particle_ao", "issm", "particle_ao"},
                            {"ray_traced", "ray_traced", "none"}, {"ray_traced + ray_traced_ao", "ray_traced", "ray_traced_ao"}};
  const Scene base = build_scene(scene_json, "");
  std::printf("\n%s (%zu spheres, image %dx%d)\n", name.c_str(), base.particles.front().set->size(), base.camera.width,
              base.camera.height);
  std::printf("| configuration              | build ms | render ms | memory MB | PSNR dB vs ray_traced (+ AO) |\n");
  std::printf("|----------------------------|---------:|----------:|----------:|-----------------------------:|\n");
  std::vector<Image> images;
  std::vector<FrameResult> frames;
  std::vector<std::size_t> memory;
  for (const Config& c : configs) {
    Scene s = base;
    s.shadows.technique = c.shadows;
    s.ambient.technique = c.ambient;
    Renderer r(s);
    frames.push_back(r.render());
    memory.push_back(r.shadow_memory_bytes() + r.ambient_memory_bytes() + r.bvh_memory_bytes());
  }
  const std::string files[] = {"ll", "issm", "issm_ao", "ray_traced", "ray_traced_ao"};
  for (std::size_t i = 0; i < frames.size(); ++i) {
    // shadows alone against shadow rays, shadows + AO against shadow rays + AO rays
    const Image& ref = std::string(configs[i].ambient) == "none" ? frames[3].image : frames[4].image;
    const ImageDifference d = compare_images(frames[i].image, ref);
    std::printf("| %-26s | %8.1f | %9.1f | %9.2f | %28.2f |\n", configs[i].label, frames[i].bvh_ms + frames[i].ambient_ms + frames[i].build_ms,
                frames[i].render_ms, static_cast<double>(memory[i]) / 1048576.0, d.psnr);
    write_image(dir + "/" + name + "_" + files[i] + ".png", frames[i].image);
  }
  write_image(dir + "/" + name + "_comparison.png",
              montage({&frames[0].image, &frames[1].image, &frames[2].image, &frames[4].image}));
  std::printf("wrote %s/%s_*.png and %s_comparison.png (local lighting | issm | issm + particle_ao | ray traced + AO)\n",
              dir.c_str(), name.c_str(), name.c_str());
}

// The bone isosurface of the procedural CT by each method, timed, with the error of each against the
// ray-cast isosurface with exact shadow rays.
void demo_isosurface(const std::string& dir, bool quick) {
  struct Config {
    const char* label;
    IsosurfaceMethod method;
    const char* shadows;
    const char* file;
  };
  const Config configs[] = {{"points", IsosurfaceMethod::Points, "none", "points"},
                            {"points + light_pass", IsosurfaceMethod::Points, "light_pass", "light_pass"},
                            {"mesh (marching cubes)", IsosurfaceMethod::Mesh, "none", "mesh"},
                            {"raycast + ray_traced", IsosurfaceMethod::Raycast, "ray_traced", "ray_traced"}};
  Timer load;
  const Scene base = build_scene(quick ? sized(ct_body_scene(64, 64, 216), 64, 64) : ct_body_scene(256, 256, 867), "");
  const auto& d = base.volumes[0].volume->dims();
  std::printf("\nct-body bone isosurface (procedural CT %dx%dx%d uint16, built in %.0f ms; image %dx%d)\n", d[0], d[1], d[2],
              load.elapsed_ms(), base.camera.width, base.camera.height);
  std::printf("| method                | cull ms | shadows ms | mesh ms | points | PSNR dB vs raycast + ray_traced |\n");
  std::printf("|-----------------------|--------:|-----------:|--------:|-------:|--------------------------------:|\n");
  std::vector<FrameResult> frames;
  for (const Config& c : configs) {
    Scene s = base;
    s.isosurfaces[0].method = c.method;
    s.shadows.technique = c.shadows;
    Renderer r(s);
    frames.push_back(r.render());
    write_image(dir + "/ct-body_" + c.file + ".png", frames.back().image);
  }
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const IsosurfaceFrameStats& st = frames[i].isosurface;
    std::printf("| %-21s | %7.1f | %10.1f | %7.0f | %6zu | %31.2f |\n", configs[i].label, st.extract_ms, st.shadow_ms, st.mesh_ms,
                st.points, compare_images(frames[i].image, frames.back().image).psnr);
  }
  write_image(dir + "/ct-body_comparison.png", montage({&frames[0].image, &frames[1].image, &frames[2].image, &frames[3].image}));
  std::printf("wrote %s/ct-body_*.png and ct-body_comparison.png (points | points + light_pass | mesh | ray traced)\n",
              dir.c_str());
}

// Mixed scenes (every caster shadows every receiver): the cranium CT under a bone transfer function with
// six metal spheres (dental implants, skull screws), and GroEL's atoms inside their own density map with
// an isosurface of its dense cores. The spheres go to a small .xyz file in `dir`.
nlohmann::json ct_implants_scene(const std::string& ct, const std::string& dir) {
  const std::string xyz = dir + "/ct-implants.xyz";
  std::FILE* f = std::fopen(xyz.c_str(), "w");
  if (!f) throw Error(xyz + ": cannot write the demo's implants");
  std::fputs("6\nmetal implants (mm, cranium_ct.nrrd's frame)\nTi 105 190 18\nTi 118 197 18\nTi 132 197 18\n"
             "Ti 145 190 18\nTi 95 150 140\nTi 150 150 140\n", f);
  std::fclose(f);
  nlohmann::json j = cranium_scene(ct);
  j["volumes"][0]["transfer_function"] = {{"preset", "ct-bone"}};
  j["particles"] = nlohmann::json::array({{{"file", xyz}, {"radius", 6}, {"color_by", "uniform"}, {"color", {0.75, 0.78, 0.82}}}});
  return j;
}

nlohmann::json groel_density_scene(const std::string& molecule) {
  return {
      {"volumes", {{{"procedural", {{"name", "molecular-density"}, {"file", molecule}, {"spacing", 2.0}, {"sigma", 2.5}}},
                    {"transfer_function", {{"points", {{0, 0.3, 0.45, 0.9, 0}, {6, 0.3, 0.45, 0.9, 0}, {9, 0.35, 0.5, 0.95, 0.04},
                                                       {20, 0.4, 0.55, 1.0, 0.08}, {60, 0.5, 0.6, 1.0, 0.12}}}}}}}},
      {"isosurfaces", {{{"volume", 0}, {"value", 70}, {"color", {0.95, 0.8, 0.35}}}}},
      {"particles", {{{"file", molecule}, {"color_by", "chain"}, {"radius_scale", 0.4}}}},
      {"planes", {{{"point", {0, 0, -150}}, {"normal", {0, 0, 1}}, {"color", {0.9, 0.9, 0.9}}, {"size", 900}}}},
      {"lights", {{{"type", "directional"}, {"direction", {-0.3, -0.4, -1.0}}}}},
      {"camera", {{"direction", {1, 0.4, 0.25}}, {"up", {0, 0, 1}}, {"fov_deg", 30}, {"zoom", 1.5}, {"width", 800}, {"height", 600}}},
      {"background", {1, 1, 1}}};
}

}  // namespace

void add_demo_command(CLI::App& app) {
  struct Options {
    std::string dir = "penumbra-demo";
    int threads = 0;
    std::string data_dir = default_data_dir();
    bool quick = false;
  };
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("demo", "Render the built-in scenes with every shadow technique");
  cmd->add_option("-o,--output", o->dir, "Output directory (created)");
  cmd->add_option("--threads", o->threads, "Worker threads (0 = all cores)")->check(CLI::Range(0, 1024));
  cmd->add_flag("--quick", o->quick, "Test-sized scenes (64² images, 128² maps, small volumes): a smoke test in seconds");
  cmd->add_option("--data-dir", o->data_dir, "Where cranium_ct.nrrd is looked for (default: $PENUMBRA_DATA_DIR or ../shared/data)");
  cmd->callback([o] {
    ThreadLimit limit(o->threads);
    std::filesystem::create_directories(o->dir);
    const bool q = o->quick;
    const int maps = q ? 128 : 1024;
    demo_scene("test-spheres", q ? sized(test_spheres_scene(32), 64, 64) : test_spheres_scene(128), o->dir, maps);
    const std::string ct = o->data_dir + "/cranium_ct.nrrd";
    if (std::filesystem::exists(ct)) demo_scene("cranium", q ? sized(cranium_scene(ct), 64, 64) : cranium_scene(ct), o->dir, maps);
    else std::printf("\n(%s not found: the CT scene is skipped)\n", ct.c_str());
    demo_particles("spheres-floor", q ? sized(spheres_floor_scene(), 64, 48) : spheres_floor_scene(), o->dir);
    const std::string groel = o->data_dir + "/1aon.pdb.gz";
    if (std::filesystem::exists(groel)) demo_particles("1aon", q ? sized(molecule_scene(groel), 64, 64) : molecule_scene(groel), o->dir);
    else std::printf("\n(%s not found: the molecule scene is skipped)\n", groel.c_str());
    demo_isosurface(o->dir, q);
    // one scene of every kind: each map technique takes the spheres, isosurfaces and planes too
    if (std::filesystem::exists(ct))
      demo_scene("ct-implants", q ? sized(ct_implants_scene(ct, o->dir), 64, 64) : ct_implants_scene(ct, o->dir), o->dir, maps);
    if (std::filesystem::exists(groel))
      demo_scene("groel-density", q ? sized(groel_density_scene(groel), 64, 48) : groel_density_scene(groel), o->dir, maps);
  });
}

}  // namespace penumbra::cli
