// Dynamic data (issue 18): trajectories beside a topology (particles[].trajectory), volume series
// (volumes[].files, a generated series) and the scene's `time` as an edit like any other — the frame
// shown equals a static scene of that frame's data byte for byte, only what moved is rebuilt, bad
// input names its key, and playing frames does not grow memory.
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/engine/engine.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene_io/scene_file.h"
#include "image_check.h"
#include "test_scenes.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

struct Atom {
  const char* element;
  Vec3 p;
};

// Frame k of a little moving system: a carbon ring on the floor and an oxygen ball flying over it, so
// its shadow sweeps across the ring.
std::vector<Atom> frame_atoms(int k) {
  std::vector<Atom> atoms;
  for (int i = 0; i < 12; ++i) {
    const float a = 0.5236f * static_cast<float>(i);
    atoms.push_back({"C", {4 * std::cos(a), 0, 4 * std::sin(a)}});
  }
  atoms.push_back({"O", {-5 + 2.5f * static_cast<float>(k), 4, 0.5f}});
  atoms.push_back({"N", {0, 1.5f + 0.3f * static_cast<float>(k), 0}});
  return atoms;
}

void write_xyz_frame(std::ofstream& out, int k) {
  const auto atoms = frame_atoms(k);
  out << atoms.size() << "\nframe " << k << "\n";
  for (const auto& a : atoms) out << a.element << " " << a.p.x << " " << a.p.y << " " << a.p.z << "\n";
}

nlohmann::json particle_scene(const nlohmann::json& particles) {
  nlohmann::json j;
  j["particles"] = nlohmann::json::array({particles});
  j["planes"] = nlohmann::json::array({{{"point", {0, -2, 0}}, {"normal", {0, 1, 0}}, {"size", 30}}});
  j["lights"] = nlohmann::json::array({{{"type", "directional"}, {"direction", {0.3, -1, -0.2}}}});
  j["camera"] = {{"eye", {0, 14, 16}}, {"target", {0, 0, 0}}, {"up", {0, 1, 0}}, {"width", 64}, {"height", 48}};
  j["shadows"] = {{"technique", "issm"}, {"resolution", 256}};
  j["ambient"] = {{"technique", "particle_ao"}};
  return j;
}

bool contains(const std::vector<RebuiltStructure>& rebuilt, const std::string& name) {
  for (const auto& r : rebuilt)
    if (r.structure == name) return true;
  return false;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

}  // namespace

// Proves that frame k of a trajectory, reached by editing `time` on a live engine (after other frames),
// is byte for byte the image of a static scene holding frame k's positions — shadows (issm) and
// ambient occlusion (particle_ao) follow the atoms — and that the flying atom's shadow really moves;
// each time edit rebuilds the spheres and what hangs off them, never a volume's structures.
TEST(Trajectory, FrameKEqualsAStaticRenderOfItsPositions) {
  ScratchDir dir;
  {
    std::ofstream topology(dir.file("top.xyz")), trajectory(dir.file("traj.xyz"));
    write_xyz_frame(topology, 0);
    for (int k = 0; k < 5; ++k) write_xyz_frame(trajectory, k);
  }
  Engine engine(particle_scene({{"file", "top.xyz"}, {"trajectory", "traj.xyz"}}), dir.path().string());
  EXPECT_EQ(engine.scene().frame_count(), 5u);
  (void)engine.render();
  FailureImages keep;
  Image previous;
  for (const int k : {3, 1, 4}) {
    engine.set("time", k);
    const EngineFrame f = engine.render();
    for (const char* name : {"spheres", "lights.0.shadows", "ambient"})
      EXPECT_TRUE(contains(f.rebuilt, name)) << "time " << k << ": " << name << " not rebuilt";
    for (const auto& r : f.rebuilt) EXPECT_NE(r.structure.rfind("volumes.", 0), 0u) << r.structure;
    {
      std::ofstream one(dir.file("frame.xyz"));
      write_xyz_frame(one, k);
    }
    const Image fresh = Renderer(build_scene(particle_scene({{"file", "frame.xyz"}}), dir.path().string())).render().image;
    keep.add("time" + std::to_string(k), f.image, fresh);
    EXPECT_EQ(compare_images(f.image, fresh).max_abs, 0.0) << "time " << k;
    if (previous.width() > 0) {
      EXPECT_GT(compare_images(f.image, previous).max_abs, 0.05) << "nothing moved at time " << k;
    }
    previous = f.image;
  }
  // an edit of anything else keeps the frame (no sphere rebuilt)
  engine.set("lights.0.intensity", 0.8);
  EXPECT_FALSE(contains(engine.render().rebuilt, "spheres"));
}

// The same beside a still set that casts no shadow (so the casting spheres are a prefix of the drawn
// ones, each with its own spatial order carried from frame to frame): frame k equals a static render.
TEST(Trajectory, FrameKEqualsAStaticRenderBesideSpheresThatCastNoShadow) {
  ScratchDir dir;
  {
    std::ofstream topology(dir.file("top.xyz")), trajectory(dir.file("traj.xyz")), still(dir.file("still.xyz"));
    write_xyz_frame(topology, 0);
    for (int k = 0; k < 5; ++k) write_xyz_frame(trajectory, k);
    write_xyz_frame(still, 2);
  }
  auto scene_with = [](const nlohmann::json& moving) {
    nlohmann::json j = particle_scene(moving);
    j["particles"].push_back({{"file", "still.xyz"}, {"casts_shadows", false}, {"origin", {1, 1, 1}}});
    return j;
  };
  Engine engine(scene_with({{"file", "top.xyz"}, {"trajectory", "traj.xyz"}}), dir.path().string());
  (void)engine.render();
  FailureImages keep;
  for (const int k : {3, 1, 4}) {
    engine.set("time", k);
    const EngineFrame f = engine.render();
    {
      std::ofstream one(dir.file("frame.xyz"));
      write_xyz_frame(one, k);
    }
    const Image fresh = Renderer(build_scene(scene_with({{"file", "frame.xyz"}}), dir.path().string())).render().image;
    keep.add("beside_time" + std::to_string(k), f.image, fresh);
    EXPECT_EQ(compare_images(f.image, fresh).max_abs, 0.0) << "time " << k;
  }
}

// Proves a trajectory given as a list of files plays their frames in order, and that the default
// camera frames the topology, so the view holds still while the atoms move.
// ambient.reuse through the engine: a time edit builds the same particle_ao again, keeping the cones of
// the atoms that moved less than `reuse` cells (8 here: the ring and the slow N atom; the O atom flies
// 2.5 Å, 13 cells) and reporting how many it kept; an edit of the ambient settings starts afresh, and a
// frame so made equals a static render of its positions byte for byte.
TEST(Trajectory, AmbientReuseKeepsTheConesOfAtomsThatMovedLittle) {
  ScratchDir dir;
  {
    std::ofstream topology(dir.file("top.xyz")), trajectory(dir.file("traj.xyz"));
    write_xyz_frame(topology, 0);
    for (int k = 0; k < 3; ++k) write_xyz_frame(trajectory, k);
  }
  nlohmann::json doc = particle_scene({{"file", "top.xyz"}, {"trajectory", "traj.xyz"}});
  doc["ambient"]["reuse"] = 8;
  Engine engine(doc, dir.path().string());
  EXPECT_EQ(engine.render().frame.ambient_kept, 0u);
  engine.set("time", 1);
  const EngineFrame moved = engine.render();
  EXPECT_TRUE(contains(moved.rebuilt, "ambient"));
  EXPECT_EQ(moved.frame.ambient_kept, frame_atoms(1).size() - 1);
  engine.set("ambient.reuse", 0.0);
  const EngineFrame afresh = engine.render();
  EXPECT_TRUE(contains(afresh.rebuilt, "ambient"));
  EXPECT_EQ(afresh.frame.ambient_kept, 0u);
  {
    std::ofstream one(dir.file("frame.xyz"));
    write_xyz_frame(one, 1);
  }
  const Image fresh = Renderer(build_scene(particle_scene({{"file", "frame.xyz"}}), dir.path().string())).render().image;
  EXPECT_EQ(compare_images(afresh.image, fresh).max_abs, 0.0);
}

TEST(Trajectory, AListOfFilesIsOneTrajectoryAndTheViewHoldsStill) {
  ScratchDir dir;
  {
    std::ofstream topology(dir.file("top.xyz")), a(dir.file("a.xyz")), b(dir.file("b.xyz"));
    write_xyz_frame(topology, 0);
    for (int k = 0; k < 2; ++k) write_xyz_frame(a, k);
    for (int k = 2; k < 5; ++k) write_xyz_frame(b, k);
  }
  nlohmann::json j = particle_scene({{"file", "top.xyz"}, {"trajectory", {"a.xyz", "b.xyz"}}});
  j.erase("camera");
  j["time"] = 3;
  const Scene s3 = build_scene(j, dir.path().string());
  j["time"] = 0;
  const Scene s0 = build_scene(j, dir.path().string());
  EXPECT_EQ(s3.frame_count(), 5u);
  const Vec3 flyer3 = s3.particles[0].set->spheres[12].center, want = frame_atoms(3)[12].p;
  EXPECT_NEAR(flyer3.x, want.x, 1e-4);
  EXPECT_NEAR(flyer3.y, want.y, 1e-4);
  EXPECT_EQ(s3.camera.eye, s0.camera.eye);
}

// Proves bad trajectories and times are refused with a message naming the key and what was expected.
TEST(Trajectory, BadInputNamesTheKey) {
  ScratchDir dir;
  {
    std::ofstream topology(dir.file("top.xyz")), trajectory(dir.file("traj.xyz")), other(dir.file("other.xyz"));
    write_xyz_frame(topology, 0);
    for (int k = 0; k < 3; ++k) write_xyz_frame(trajectory, k);
    other << "2\nfewer atoms\nC 0 0 0\nC 1 0 0\n";
  }
  const std::string base = dir.path().string();
  auto build = [&](nlohmann::json particles, int time = 0) {
    nlohmann::json j = particle_scene(particles);
    j["time"] = time;
    return error_of([&] { build_scene(j, base); });
  };
  std::string e = build({{"file", "top.xyz"}, {"trajectory", "traj.xyz"}}, 3);
  EXPECT_NE(e.find("time"), std::string::npos) << e;
  EXPECT_NE(e.find("3 frames"), std::string::npos) << e;
  e = build({{"file", "top.xyz"}, {"trajectory", "other.xyz"}});
  EXPECT_NE(e.find("particles.0.trajectory"), std::string::npos) << e;
  EXPECT_NE(e.find("14"), std::string::npos) << e;  // the topology's atom count
  e = build({{"file", "top.xyz"}, {"trajectory", "traj.xyz"}, {"assembly", 1}});
  EXPECT_NE(e.find("particles.0.assembly"), std::string::npos) << e;
  e = build({{"file", "top.xyz"}, {"trajectory", "traj.xyz"}, {"hydrogens", false}});
  EXPECT_NE(e.find("particles.0.hydrogens"), std::string::npos) << e;
  e = build({{"trajectory", "traj.xyz"}, {"procedural", {{"name", "random-spheres"}}}});
  EXPECT_NE(e.find("topology"), std::string::npos) << e;
  e = build({{"file", "top.xyz"}, {"trajectory", "missing.xyz"}});
  EXPECT_NE(e.find("missing.xyz"), std::string::npos) << e;
  e = build({{"file", "top.xyz"}, {"trajectory", nlohmann::json::array()}});
  EXPECT_NE(e.find("particles.0.trajectory"), std::string::npos) << e;
  // a time edit past the end is refused and the engine keeps its frame
  Engine engine(particle_scene({{"file", "top.xyz"}, {"trajectory", "traj.xyz"}}), base);
  engine.set("time", 2);
  EXPECT_NE(error_of([&] { engine.set("time", 7); }).find("time"), std::string::npos);
  EXPECT_EQ(engine.scene().time, 2u);
}

// Proves a multi-model mmCIF plays as a trajectory beside an mmCIF topology: `time` k shows model k+1,
// byte for byte the static render of frame k's positions.
TEST(Trajectory, MmcifModelsAreFrames) {
  ScratchDir dir;
  const auto write_cif = [&](const std::string& name, int models) {
    std::ofstream out(dir.file(name));
    out << "data_moving\nloop_\n_atom_site.group_PDB\n_atom_site.id\n_atom_site.type_symbol\n_atom_site.label_atom_id\n"
           "_atom_site.label_alt_id\n_atom_site.label_comp_id\n_atom_site.label_asym_id\n_atom_site.Cartn_x\n"
           "_atom_site.Cartn_y\n_atom_site.Cartn_z\n_atom_site.occupancy\n_atom_site.B_iso_or_equiv\n"
           "_atom_site.auth_seq_id\n_atom_site.auth_asym_id\n_atom_site.pdbx_PDB_model_num\n";
    int id = 0;
    for (int k = 0; k < models; ++k) {
      const auto atoms = frame_atoms(k);
      for (std::size_t i = 0; i < atoms.size(); ++i)  // printed as write_xyz_frame prints them: the same floats
        out << "HETATM " << ++id << " " << atoms[i].element << " " << atoms[i].element << i << " . MOV A " << atoms[i].p.x
            << " " << atoms[i].p.y << " " << atoms[i].p.z << " 1 0 1 A " << k + 1 << "\n";
    }
  };
  write_cif("top.cif", 1);
  write_cif("traj.cif", 3);
  {
    std::ofstream one(dir.file("frame.xyz"));
    write_xyz_frame(one, 2);
  }
  Engine engine(particle_scene({{"file", "top.cif"}, {"trajectory", "traj.cif"}}), dir.path().string());
  EXPECT_EQ(engine.scene().frame_count(), 3u);
  const Image first = engine.render().image;
  engine.set("time", 2);
  const EngineFrame f = engine.render();
  EXPECT_TRUE(contains(f.rebuilt, "spheres"));
  const Image fresh = Renderer(build_scene(particle_scene({{"file", "frame.xyz"}}), dir.path().string())).render().image;
  FailureImages keep;
  keep.add("mmcif_time2", f.image, fresh);
  EXPECT_EQ(compare_images(f.image, fresh).max_abs, 0.0);
  EXPECT_GT(compare_images(f.image, first).max_abs, 0.05);
}

namespace {

// A uint8 NRRD volume of size³ voxels holding a cube of `value` shifted by `shift` along x.
void write_nrrd_step(const std::string& file, int shift, std::uint8_t value, int size = 8) {
  std::vector<std::uint8_t> v(static_cast<std::size_t>(size * size * size), 0);
  for (int z = 2; z < 5; ++z)
    for (int y = 2; y < 5; ++y)
      for (int x = 1 + shift; x < 4 + shift && x < size; ++x) v[static_cast<std::size_t>((z * size + y) * size + x)] = value;
  std::ofstream out(file, std::ios::binary);
  out << "NRRD0004\ntype: uint8\ndimension: 3\nsizes: " << size << " " << size << " " << size << "\nencoding: raw\n\n";
  out.write(reinterpret_cast<const char*>(v.data()), static_cast<std::streamsize>(v.size()));
}

nlohmann::json series_scene(const nlohmann::json& files) {
  nlohmann::json j;
  j["volumes"] = nlohmann::json::array({{{"files", files}, {"transfer_function", constant_tf(0.9, 0.6, 0.3, 0.5)}}});
  j["camera"] = {{"width", 24}, {"height", 24}};
  return j;
}

}  // namespace

// Proves a volume series given by a printf pattern (numbered from 0 or 1) or by a list loads step
// `time` — the voxels of that file — and refuses a step whose grid differs, a bad pattern and a time
// past the last step, naming the key and the file.
TEST(VolumeSeries, PatternAndListLoadTheStepAndCheckTheGrid) {
  ScratchDir dir;
  for (int k = 1; k <= 3; ++k) write_nrrd_step(dir.file("step_" + std::to_string(k) + ".nrrd"), k, static_cast<std::uint8_t>(60 * k));
  write_nrrd_step(dir.file("wide.nrrd"), 0, 90, 9);
  const std::string base = dir.path().string();
  nlohmann::json j = series_scene("step_%d.nrrd");
  j["time"] = 2;
  const Scene s = build_scene(j, base);
  EXPECT_EQ(s.frame_count(), 3u);
  EXPECT_EQ(s.volumes[0].source, dir.file("step_3.nrrd"));
  EXPECT_EQ(s.volumes[0].volume->max_value(), 180.0f);
  j = series_scene(nlohmann::json::array({"step_3.nrrd", "step_1.nrrd"}));
  j["time"] = 1;
  EXPECT_EQ(build_scene(j, base).volumes[0].volume->max_value(), 60.0f);

  EXPECT_NE(error_of([&] { build_scene(series_scene("step_%s.nrrd"), base); }).find("volumes.0.files"), std::string::npos);
  EXPECT_NE(error_of([&] { build_scene(series_scene("none_%03d.nrrd"), base); }).find("none_000.nrrd"), std::string::npos);
  j = series_scene("step_%d.nrrd");
  j["time"] = 3;
  EXPECT_NE(error_of([&] { build_scene(j, base); }).find("3 steps"), std::string::npos);
  // the engine meets the wide step after a regular one: same grid required
  Engine engine(series_scene(nlohmann::json::array({"step_1.nrrd", "wide.nrrd"})), base);
  (void)engine.render();
  const std::string e = error_of([&] { engine.set("time", 1); });
  EXPECT_NE(e.find("wide.nrrd"), std::string::npos) << e;
  EXPECT_NE(e.find("9×9×9"), std::string::npos) << e;
  EXPECT_EQ(engine.scene().time, 0u);
}

// Proves the generated series (a ball orbiting the y axis) casts a shadow that moves with it: at each
// time the engine's frame equals a fresh render of that time byte for byte, and consecutive frames
// differ; the transfer function keeps the first step's range.
TEST(VolumeSeries, AGeneratedSeriesShadowsEachStep) {
  nlohmann::json j;
  j["volumes"] = nlohmann::json::array({{{"procedural", {{"name", "sphere"}, {"size", 24}, {"radius", 0.15}, {"frames", 6}}},
                                         {"transfer_function", {{"points", {{0.0, 0, 0, 0, 0.0}, {0.5, 0.9, 0.5, 0.3, 0.0},
                                                                             {1.0, 0.9, 0.5, 0.3, 0.9}}}}}}});
  j["planes"] = nlohmann::json::array({{{"point", {0, -0.6, 0}}, {"normal", {0, 1, 0}}, {"size", 3}}});
  j["lights"] = nlohmann::json::array({{{"type", "directional"}, {"direction", {0.2, -1, 0.1}}}});
  j["camera"] = {{"eye", {0, 1.5, 2.2}}, {"target", {0, -0.3, 0}}, {"width", 40}, {"height", 32}};
  j["shadows"] = {{"technique", "cssm"}, {"resolution", 128}};
  Engine engine(j, "");
  EXPECT_EQ(engine.scene().frame_count(), 6u);
  Image previous = engine.render().image;
  FailureImages keep;
  for (const int k : {2, 5}) {
    engine.set("time", k);
    const Image live = engine.render().image;
    nlohmann::json at = j;
    at["time"] = k;
    const Image fresh = Renderer(build_scene(at, "")).render().image;
    keep.add("time" + std::to_string(k), live, fresh);
    EXPECT_EQ(compare_images(live, fresh).max_abs, 0.0) << k;
    EXPECT_GT(compare_images(live, previous).max_abs, 0.05) << k;
    previous = live;
  }
}

// Proves playing a trajectory does not grow resident memory with the number of frames: after 40 time
// edits (each reading its frame, rebuilding spheres, shadows and AO), RSS stays within 8 MiB of where
// it was after the first 10 (a kept frame is 14 spheres here, so a leak shows only through the
// structures: this scene is sized so each frame's issm and AO hold ~1 MiB).
TEST(Trajectory, PlayingFramesDoesNotGrowMemory) {
  ScratchDir dir;
  {
    std::ofstream topology(dir.file("top.xyz")), trajectory(dir.file("traj.xyz"));
    write_xyz_frame(topology, 0);
    for (int k = 0; k < 50; ++k) write_xyz_frame(trajectory, k % 5);
  }
  Engine engine(particle_scene({{"file", "top.xyz"}, {"trajectory", "traj.xyz"}}), dir.path().string());
  auto resident = [] {
    std::ifstream in("/proc/self/statm");
    std::uint64_t pages = 0, rss = 0;
    in >> pages >> rss;
    return rss * static_cast<std::uint64_t>(sysconf(_SC_PAGESIZE));
  };
  std::uint64_t after_warmup = 0;
  for (int k = 0; k < 50; ++k) {
    engine.set("time", k);
    (void)engine.render();
    if (k == 9) after_warmup = resident();
  }
  const std::uint64_t after = resident();
  if (after_warmup == 0) GTEST_SKIP() << "no /proc/self/statm";
  // the sanitizers' quarantine (freed memory held back to catch use-after-free) grows the resident
  // size by design; LeakSanitizer checks this test's frames for leaks there instead
  if (sanitize_scale()) GTEST_SKIP() << "resident size is not meaningful under the sanitizers";
  EXPECT_LT(after, after_warmup + (8u << 20)) << "RSS grew from " << after_warmup << " to " << after;
}
