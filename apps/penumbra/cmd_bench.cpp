// `penumbra bench`: suite `cssm` — the CSSM paper's Tables 3 (generation time) and 4 (rendering time) on
// this machine, for shadow_map, deep_shadow_map (3 nodes) and cssm (13 offsets) at several shadow-map
// resolutions and a 512² frame, on test-spheres 128³ and cranium_ct.nrrd — plus what the paper lacks:
// memory per technique and error (RMSE, PSNR) against the exact ray-traced image; suite `dsm` — cssm
// against both deep shadow map layouts and the classic map at the paper's settings and at equal memory
// (bench_dsm.cpp); suite `extinction` — paper 001's Tables 1–3 (bench_extinction.cpp); suite `particles`
// — paper 003's Fig. 8 (bench_particles.cpp); suite `isosurface` — paper 002's Table 1
// (bench_isosurface.cpp). Markdown on stdout and in DIR/bench.md, JSON in DIR/bench.json; both begin with
// the provenance (commit, date, CPU, cores, threads: bench_provenance.h). `--quick` runs every suite on
// small procedural data (and 1tii for the particles) in seconds: a check that the bench works, not figures.
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "commands.h"
#include "penumbra/core/error.h"
#include "penumbra/core/image_io.h"
#include "penumbra/core/parallel.h"
#include "penumbra/scene_io/demo_scenes.h"
#include "bench_dsm.h"
#include "bench_extinction.h"
#include "bench_isosurface.h"
#include "bench_particles.h"
#include "bench_provenance.h"
#include "stats.h"
#include "technique_runs.h"

namespace penumbra::cli {
namespace {

struct Options {
  std::string dir = "penumbra-bench";
  std::string data_dir = default_data_dir();
  std::vector<int> resolutions{1024, 2048, 4096};
  std::vector<std::string> datasets{"test-spheres", "cranium"};
  int repeats = 3;
  int size = 512;
  int threads = 0;
  std::vector<std::string> suites{"cssm", "dsm", "extinction"};
  std::vector<std::string> dsm_datasets{"test-spheres", "cranium"};
  int dsm_resolution = 1024;
  int test_spheres_size = 128;
  bool quick = false;
  bool no_charts = false;
  std::vector<std::string> extinction_datasets{"procedural", "cranium", "chest"};
  int max_sampled_size = 128;
  std::vector<std::string> particle_datasets = ParticleBenchOptions{}.datasets;
  int width = 1920;   // particles suite: frame width and height (paper 003's 1920×1200)
  int height = 1200;
  std::vector<std::string> isosurface_datasets = IsosurfaceBenchOptions{}.datasets;
  std::vector<int> body_dims{512, 512, 1734};
  bool no_mesh = false;
};

// --quick: every suite on small procedural data (1tii for the particles, when found), one repeat.
void make_quick(Options& o) {
  o.suites = {"cssm", "dsm", "extinction", "isosurface"};
  if (std::filesystem::exists(o.data_dir + "/1tii.pdb")) o.suites.push_back("particles");
  o.resolutions = {48, 64};
  o.datasets = {"test-spheres"};
  o.dsm_datasets = {"test-spheres"};
  o.dsm_resolution = 64;
  o.test_spheres_size = 24;
  o.repeats = 1;
  o.size = 40;
  o.extinction_datasets = {"procedural"};
  o.max_sampled_size = 12;
  o.particle_datasets = {"1tii"};
  o.width = 96;
  o.height = 60;
  o.isosurface_datasets = {"ct-body"};
  o.body_dims = {24, 24, 64};
}

nlohmann::json dataset_scene(const Options& o, const std::string& d, const char* option) {
  if (d == "test-spheres") return test_spheres_scene(o.test_spheres_size);
  if (d == "cranium") {
    const std::string ct = o.data_dir + "/cranium_ct.nrrd";
    if (!std::filesystem::exists(ct)) throw Error(std::string(option) + " cranium: " + ct + " not found (see --data-dir)");
    return cranium_scene(ct);
  }
  throw Error(std::string(option) + ": unknown data set '" + d + "' (expected test-spheres or cranium)");
}

// Per scene, the techniques' error against frame time (scripts/bench_charts.py, matplotlib): PNGs and
// charts.md beside bench.md. Optional: without Python or matplotlib the script says so and nothing fails.
void draw_charts(const std::string& dir) {
  const std::string script = std::string(PENUMBRA_SOURCE_DIR) + "/scripts/bench_charts.py";
  if (!std::filesystem::exists(script) || dir.find('\'') != std::string::npos) {
    std::fprintf(stderr, "bench: charts not drawn (%s not found, or the output folder's name holds a quote)\n", script.c_str());
    return;
  }
  std::fflush(stdout);
  const std::string command = "python3 '" + script + "' '" + dir + "' 1>&2";
  if (std::system(command.c_str()) != 0) std::fprintf(stderr, "bench: charts not drawn (%s failed)\n", script.c_str());
}

void bench_dataset(const Options& o, const std::string& name, const nlohmann::json& scene_in, std::ostringstream& md,
                   nlohmann::json& out) {
  nlohmann::json scene = scene_in;
  scene["camera"]["width"] = o.size;
  scene["camera"]["height"] = o.size;
  std::fprintf(stderr, "bench %s: reference and frame without shadows...\n", name.c_str());
  const TechniqueRun none = run_technique(scene, "none", 1024, {}, o.repeats);
  const TechniqueRun reference = run_technique(scene, "ray_traced", 1024, {}, 1);
  write_image(o.dir + "/" + name + "_ray_traced.png", reference.image);
  const std::vector<std::string> techniques{"shadow_map", "deep_shadow_map", "cssm"};
  std::vector<std::vector<TechniqueRun>> runs(o.resolutions.size());
  for (std::size_t r = 0; r < o.resolutions.size(); ++r)
    for (const auto& t : techniques) {
      std::fprintf(stderr, "bench %s: %s at %d²...\n", name.c_str(), t.c_str(), o.resolutions[r]);
      TechniqueRun run = run_technique(scene, t, o.resolutions[r], {}, o.repeats);
      const ImageDifference d = compare_images(run.image, reference.image);
      run.rmse = d.rmse;
      run.psnr = d.psnr;
      write_image(o.dir + "/" + name + "_" + t + "_" + std::to_string(o.resolutions[r]) + ".png", run.image);
      runs[r].push_back(std::move(run));
    }

  char line[512];
  md << "\n### " << name << " (" << o.size << "² frame)\n\n";
  std::snprintf(line, sizeof line, "Frame without shadows: %.1f ms. Ray-traced reference: %.1f ms.\n\n", none.render_ms,
                reference.render_ms);
  md << line;
  auto table = [&](const char* title, auto cell) {
    md << "**" << title << "**\n\n| resolution | shadow_map | deep_shadow_map (3 nodes) | cssm (13 offsets) |\n|---|---:|---:|---:|\n";
    for (std::size_t r = 0; r < o.resolutions.size(); ++r) {
      md << "| " << o.resolutions[r] << "² ";
      for (const auto& run : runs[r]) md << "| " << cell(run) << " ";
      md << "|\n";
    }
    md << "\n";
  };
  auto fmt = [](const char* f, double v) {
    char b[64];
    std::snprintf(b, sizeof b, f, v);
    return std::string(b);
  };
  table("Generation (build) time, ms — paper Table 3", [&](const TechniqueRun& r) { return fmt("%.1f", r.build_ms); });
  table("Rendering time with the map, ms — paper Table 4", [&](const TechniqueRun& r) { return fmt("%.1f", r.render_ms); });
  table("Memory of the map, MiB", [&](const TechniqueRun& r) { return fmt("%.1f", static_cast<double>(r.memory_bytes) / 1048576.0); });
  table("Error against ray_traced: RMSE / PSNR dB", [&](const TechniqueRun& r) {
    return fmt("%.4f", r.rmse) + " / " + fmt("%.1f", r.psnr);
  });
  const TechniqueRun& sm = runs[0][0];
  const TechniqueRun& cssm = runs[0][2];
  std::snprintf(line, sizeof line,
                "At %d²: cssm rendering costs %.2f× the frame without shadows (target ≤ 2×; paper ≈ 1.5×); "
                "cssm generation costs %.2f× the classic map's (target ≤ 1.3×; paper ≈ 1.2×).\n",
                o.resolutions[0], cssm.render_ms / none.render_ms, cssm.build_ms / sm.build_ms);
  md << line;

  nlohmann::json j;
  j["frame_without_shadows_ms"] = none.render_ms;
  j["ray_traced_ms"] = reference.render_ms;
  for (std::size_t r = 0; r < o.resolutions.size(); ++r)
    for (const auto& run : runs[r])
      j["runs"].push_back({{"technique", run.technique}, {"resolution", run.resolution}, {"build_ms", run.build_ms},
                           {"render_ms", run.render_ms}, {"memory_bytes", run.memory_bytes}, {"rmse", run.rmse},
                           {"psnr", run.psnr}});
  out["datasets"][name] = j;
}

}  // namespace

void add_bench_command(CLI::App& app) {
  auto o = std::make_shared<Options>();
  CLI::App* cmd = app.add_subcommand("bench", "Reproduce the CSSM paper's Tables 3 and 4 on this machine, with memory and error columns");
  cmd->add_option("-o,--output", o->dir, "Directory for bench.md, bench.json and the images");
  cmd->add_option("--data-dir", o->data_dir, "Where cranium_ct.nrrd is looked for (default: $PENUMBRA_DATA_DIR or ../shared/data)");
  cmd->add_option("--resolutions", o->resolutions, "Shadow-map resolutions")->check(CLI::Range(16, 16384));
  cmd->add_option("--datasets", o->datasets, "test-spheres and/or cranium");
  cmd->add_option("--repeats", o->repeats, "Runs per measurement (the fastest is kept)")->check(CLI::Range(1, 100));
  cmd->add_option("--size", o->size, "Frame width and height")->check(CLI::Range(16, 8192));
  cmd->add_option("--threads", o->threads, "Worker threads (0 = all cores)")->check(CLI::Range(0, 1024));
  cmd->add_option("--suite", o->suites,
                  "cssm (paper 000, Tables 3/4), dsm (cssm vs both deep shadow map layouts, issue 12), extinction (paper 001, "
                  "Tables 1-3), particles (paper 003, Fig. 8) and/or isosurface (paper 002, Table 1)");
  cmd->add_option("--extinction-datasets", o->extinction_datasets, "procedural (test-spheres 256³), cranium and/or chest");
  cmd->add_option("--max-sampled-size", o->max_sampled_size, "Largest light cache the sampled-AO reference is timed at")
      ->check(CLI::Range(4, 512));
  cmd->add_option("--particle-datasets", o->particle_datasets, "1tii, 1af6, 1aon, bace1, 3j6r and/or 1m4x");
  cmd->add_option("--width", o->width, "Frame width of the particles suite")->check(CLI::Range(16, 8192));
  cmd->add_option("--height", o->height, "Frame height of the particles suite")->check(CLI::Range(16, 8192));
  cmd->add_option("--isosurface-datasets", o->isosurface_datasets, "ct-body, cranium and/or chest");
  cmd->add_option("--body-dims", o->body_dims, "Dimensions of the procedural ct-body volume (default 512 512 1734)")
      ->expected(3)
      ->check(CLI::Range(8, 2048));
  cmd->add_flag("--no-mesh", o->no_mesh, "Isosurface suite: skip the marching-cubes baseline");
  cmd->add_option("--dsm-datasets", o->dsm_datasets, "Suite dsm: test-spheres and/or cranium");
  cmd->add_option("--dsm-resolution", o->dsm_resolution, "Suite dsm: the paper's map resolution (1024)")->check(CLI::Range(16, 16384));
  cmd->add_flag("--no-charts", o->no_charts, "Do not draw the error-against-time charts (scripts/bench_charts.py)");
  cmd->add_flag("--quick", o->quick,
                "Every suite on small procedural data in seconds (overrides the sizes and data sets): checks that the bench runs");
  cmd->callback([o] {
    if (o->quick) make_quick(*o);
    ThreadLimit limit(o->threads);
    std::filesystem::create_directories(o->dir);
    std::ostringstream md;
    nlohmann::json out;
    const Provenance provenance = current_provenance(ThreadLimit::current_max());
    out["provenance"] = to_json(provenance);
    out["quick"] = o->quick;
    out["suites"] = o->suites;
    for (const auto& s : o->suites)
      if (s != "cssm" && s != "dsm" && s != "extinction" && s != "particles" && s != "isosurface")
        throw Error("--suite: unknown suite '" + s + "' (expected cssm, dsm, extinction, particles or isosurface)");
    auto runs = [&](const char* suite) { return std::find(o->suites.begin(), o->suites.end(), suite) != o->suites.end(); };
    md << to_markdown(provenance) << " Fastest of " << o->repeats << " runs." << (o->quick ? " Quick mode: tiny sizes, not figures." : "")
       << "\n";
    if (runs("cssm")) md << "\n## CSSM paper Tables 3 and 4 on this machine\n";
    for (const auto& d : runs("cssm") ? o->datasets : std::vector<std::string>{})
      bench_dataset(*o, d, dataset_scene(*o, d, "--datasets"), md, out);
    if (runs("dsm")) {
      DsmBenchOptions b;
      b.dir = o->dir;
      for (const auto& d : o->dsm_datasets) b.scenes.emplace_back(d, dataset_scene(*o, d, "--dsm-datasets"));
      b.resolution = o->dsm_resolution;
      b.repeats = o->repeats;
      b.size = o->size;
      bench_dsm(b, md, out["dsm"]);
    }
    if (runs("extinction")) {
      ExtinctionBenchOptions e;
      e.dir = o->dir;
      e.data_dir = o->data_dir;
      e.datasets = o->extinction_datasets;
      e.repeats = o->repeats;
      e.size = o->size;
      e.max_sampled_size = o->max_sampled_size;
      if (o->quick) {
        e.cache_sizes = {8, 12};
        e.accuracy_cache = 8;
        e.procedural_size = 24;
        e.frame_cache = 16;
      }
      bench_extinction(e, md, out["extinction"]);
    }
    if (runs("particles")) {
      ParticleBenchOptions p;
      p.dir = o->dir;
      p.data_dir = o->data_dir;
      p.datasets = o->particle_datasets;
      p.repeats = o->repeats;
      p.width = o->width;
      p.height = o->height;
      bench_particles(p, md, out["particles"]);
    }
    if (runs("isosurface")) {
      IsosurfaceBenchOptions b;
      b.dir = o->dir;
      b.data_dir = o->data_dir;
      b.datasets = o->isosurface_datasets;
      b.body_dims = {o->body_dims[0], o->body_dims[1], o->body_dims[2]};
      b.repeats = o->repeats;
      b.size = o->size;
      b.mesh = !o->no_mesh;
      bench_isosurface(b, md, out["isosurface"]);
    }
    std::printf("%s", md.str().c_str());
    std::ofstream(o->dir + "/bench.md") << md.str();
    write_json_file(o->dir + "/bench.json", out);
    if (!o->no_charts) draw_charts(o->dir);
  });
}

}  // namespace penumbra::cli
