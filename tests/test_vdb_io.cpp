// OpenVDB grids and the bricked volume they load into. Files are written here with the OpenVDB library
// (fog blobs far apart, a level-set sphere, a double grid with tiles, several grids, transforms); every
// voxel of the loaded volume must equal the grid's value there, the memory must stay near the occupied
// bricks', and every renderer path must draw the bricked volume exactly as its dense copy (the layout
// may change where voxels live, never what is drawn). Bad files give a penumbra::Error naming the file.
#include <gtest/gtest.h>
#include <openvdb/io/File.h>
#include <openvdb/openvdb.h>
#include <openvdb/tools/LevelSetSphere.h>

#include <cmath>
#include <cstring>
#include <fstream>
#include <memory>
#include <random>
#include <string>

#include "penumbra/core/error.h"
#include "penumbra/data/io/volume_io.h"
#include "penumbra/data/volume_stats.h"
#include "penumbra/render/prepared_volume.h"
#include "penumbra/render/renderer.h"
#include "penumbra/scene_io/data_scene.h"
#include "penumbra/scene_io/scene_file.h"
#include "test_volume_io_util.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

void write_grids(const std::string& path, const openvdb::GridPtrVec& grids) {
  openvdb::initialize();
  openvdb::io::File(path).write(grids);
}

// Three soft balls (radius 6 voxels) far apart: a box of about 70³ voxels, mostly empty.
openvdb::FloatGrid::Ptr blobs() {
  auto g = openvdb::FloatGrid::create(0.0f);
  g->setName("density");
  g->setGridClass(openvdb::GRID_FOG_VOLUME);
  auto acc = g->getAccessor();
  for (const openvdb::Coord c : {openvdb::Coord(-3, 2, 1), openvdb::Coord(60, -5, 9), openvdb::Coord(20, 50, 61)})
    for (int i = -6; i <= 6; ++i)
      for (int j = -6; j <= 6; ++j)
        for (int k = -6; k <= 6; ++k) {
          const float r = std::sqrt(static_cast<float>(i * i + j * j + k * k));
          if (r < 6) acc.setValueOn(c.offsetBy(i, j, k), 1.0f - r / 6);
        }
  return g;
}

Volume load_vdb(const std::string& path, const std::string& grid = "", VolumeFileInfo* info = nullptr) {
  VolumeLoadOptions o;
  o.grid = grid;
  return load_volume(path, o, info);
}

// The aligned low corner the loader uses: the active box's minimum, down to a multiple of 8.
openvdb::Coord aligned_low(const openvdb::GridBase& g) {
  openvdb::Coord lo = g.evalActiveVoxelBoundingBox().min();
  for (int a = 0; a < 3; ++a) lo[a] = static_cast<int>(std::floor(lo[a] / 8.0)) * 8;
  return lo;
}

// Every voxel of `v` equals the grid's value at the same index.
template <class Grid> void expect_every_voxel(const Volume& v, const Grid& grid) {
  const openvdb::Coord lo = aligned_low(grid);
  const openvdb::Coord hi = grid.evalActiveVoxelBoundingBox().max();
  ASSERT_EQ(v.dims()[0], hi[0] - lo[0] + 1);
  ASSERT_EQ(v.dims()[1], hi[1] - lo[1] + 1);
  ASSERT_EQ(v.dims()[2], hi[2] - lo[2] + 1);
  auto acc = grid.getConstAccessor();
  int wrong = 0;
  for (int k = 0; k < v.dims()[2]; ++k)
    for (int j = 0; j < v.dims()[1]; ++j)
      for (int i = 0; i < v.dims()[0]; ++i) {
        const float want = static_cast<float>(acc.getValue(lo.offsetBy(i, j, k)));
        if (v.value(i, j, k) != want && ++wrong <= 5)
          ADD_FAILURE() << "voxel (" << i << ", " << j << ", " << k << "): " << v.value(i, j, k) << ", grid " << want;
      }
  EXPECT_EQ(wrong, 0);
  // Exactly the bricks whose reach (their voxels and one beyond, clamped) holds more than one value
  // are stored; the flat ones are shared.
  constexpr int C = Volume::kBrickCells;
  const auto& g = v.brick_grid();
  int misplaced = 0;
  for (int bz = 0; bz < g[2]; ++bz)
    for (int by = 0; by < g[1]; ++by)
      for (int bx = 0; bx < g[0]; ++bx) {
        const int b[3] = {bx, by, bz};
        int r0[3], r1[3];
        for (int a = 0; a < 3; ++a) {
          r0[a] = std::max(C * b[a] - 1, 0);
          r1[a] = std::min(C * b[a] + C + 1, v.dims()[a] - 1);
        }
        const float first = static_cast<float>(acc.getValue(lo.offsetBy(r0[0], r0[1], r0[2])));
        bool flat = true;
        for (int k = r0[2]; k <= r1[2]; ++k)
          for (int j = r0[1]; j <= r1[1]; ++j)
            for (int i = r0[0]; i <= r1[0]; ++i) flat = flat && static_cast<float>(acc.getValue(lo.offsetBy(i, j, k))) == first;
        if (flat != v.brick_is_shared(bx, by, bz) && ++misplaced <= 5)
          ADD_FAILURE() << "brick (" << bx << ", " << by << ", " << bz << ") is " << (flat ? "flat but stored" : "varied but shared");
      }
  EXPECT_EQ(misplaced, 0);
}

void expect_error(const std::string& path, const std::string& grid, std::initializer_list<const char*> parts) {
  try {
    load_vdb(path, grid);
    ADD_FAILURE() << "no penumbra::Error loading " << path;
  } catch (const Error& e) {
    const std::string msg = e.what();
    EXPECT_NE(msg.find(path), std::string::npos) << "message lacks the file name: " << msg;
    for (const char* part : parts) EXPECT_NE(msg.find(part), std::string::npos) << "message lacks '" << part << "': " << msg;
  }
}

// A smooth function with structure at every scale of the brick grid, for bricked-against-dense checks.
float field(int i, int j, int k) {
  return std::sin(0.37f * static_cast<float>(i)) * std::cos(0.23f * static_cast<float>(j)) + 0.05f * static_cast<float>(k % 7);
}

// The same function as a dense volume and as a bricked one in which every brick whose reach is
// outside the ball of radius `r` around voxel (c, c, c) is shared with value 0 (and the function is 0
// there too), so that both layouts, shared bricks included, hold the same voxels.
struct Pair {
  Volume dense, bricked;
};
Pair make_pair(std::array<int, 3> dims, float r) {
  auto f = [&](int i, int j, int k) {
    const float c = 0.5f * static_cast<float>(dims[0]);
    const float x = static_cast<float>(i) - c, y = static_cast<float>(j) - c, z = static_cast<float>(k) - c;
    const float d = std::sqrt(x * x + y * y + z * z);
    return d < r ? field(i, j, k) : 0.0f;
  };
  Pair p{Volume(ScalarType::Float32, dims, {0.5f, 0.25f, 1.0f}, {-1, 2, 3}), Volume()};
  for (int k = 0; k < dims[2]; ++k)
    for (int j = 0; j < dims[1]; ++j)
      for (int i = 0; i < dims[0]; ++i) p.dense.set_value(p.dense.index(i, j, k), f(i, j, k));
  p.dense.recompute_range();
  constexpr int C = Volume::kBrickCells;
  auto shared = [&](const std::array<int, 3>& b) -> std::optional<float> {
    for (int k = std::max(C * b[2] - 1, 0); k <= std::min(C * b[2] + C + 1, dims[2] - 1); ++k)
      for (int j = std::max(C * b[1] - 1, 0); j <= std::min(C * b[1] + C + 1, dims[1] - 1); ++j)
        for (int i = std::max(C * b[0] - 1, 0); i <= std::min(C * b[0] + C + 1, dims[0] - 1); ++i)
          if (f(i, j, k) != 0.0f) return std::nullopt;
    return 0.0f;
  };
  auto fill = [&](const std::array<int, 3>& b, float* out) {
    for (int z = 0; z < Volume::kBrickSide; ++z)
      for (int y = 0; y < Volume::kBrickSide; ++y)
        for (int x = 0; x < Volume::kBrickSide; ++x)
          *out++ = f(std::min(C * b[0] + x, dims[0] - 1), std::min(C * b[1] + y, dims[1] - 1), std::min(C * b[2] + z, dims[2] - 1));
  };
  p.bricked = Volume::bricked(dims, p.dense.spacing(), p.dense.origin(), shared, fill);
  return p;
}

}  // namespace

TEST(BrickedVolume, HoldsTheSameVoxelsAsTheDenseLayout) {
  for (const std::array<int, 3> dims : {std::array<int, 3>{19, 9, 30}, std::array<int, 3>{40, 40, 40},
                                        std::array<int, 3>{1, 12, 17}, std::array<int, 3>{25, 2, 10}}) {
    SCOPED_TRACE(std::to_string(dims[0]) + "x" + std::to_string(dims[1]) + "x" + std::to_string(dims[2]));
    const Pair p = make_pair(dims, 0.4f * static_cast<float>(dims[0]));
    ASSERT_TRUE(p.bricked.is_bricked());
    EXPECT_EQ(p.bricked.voxel_count(), p.dense.voxel_count());
    for (int k = 0; k < dims[2]; ++k)
      for (int j = 0; j < dims[1]; ++j)
        for (int i = 0; i < dims[0]; ++i) ASSERT_EQ(p.bricked.value(i, j, k), p.dense.value(i, j, k)) << i << " " << j << " " << k;
    EXPECT_EQ(p.bricked.min_value(), p.dense.min_value());
    EXPECT_EQ(p.bricked.max_value(), p.dense.max_value());
    // Trilinear samples anywhere (outside the box too: clamped the same way) and gradients.
    std::mt19937 rng(7);
    std::uniform_real_distribution<float> u(-2.0f, 1.0f);
    for (int n = 0; n < 2000; ++n) {
      const Vec3 v{u(rng) * static_cast<float>(dims[0]) + 2.0f * static_cast<float>(dims[0]) / 3,
                   u(rng) * static_cast<float>(dims[1]) + 2.0f * static_cast<float>(dims[1]) / 3,
                   u(rng) * static_cast<float>(dims[2]) + 2.0f * static_cast<float>(dims[2]) / 3};
      ASSERT_EQ(p.bricked.sample_voxel(v), p.dense.sample_voxel(v)) << v.x << " " << v.y << " " << v.z;
      const Vec3 w = p.dense.origin() + Vec3{v.x * 0.5f, v.y * 0.25f, v.z};
      ASSERT_EQ(p.bricked.gradient(w), p.dense.gradient(w));
    }
    // Whole-volume walks: the histogram counts every voxel of the grid once.
    const VolumeHistogram hb = compute_histogram(p.bricked, 32), hd = compute_histogram(p.dense, 32);
    EXPECT_EQ(hb.counts, hd.counts);
    EXPECT_DOUBLE_EQ(hb.mean, hd.mean);
    std::size_t seen = 0;
    p.bricked.for_each_value([&](float, std::size_t n) { seen += n; });
    EXPECT_EQ(seen, p.bricked.voxel_count());
    // The dense copy of the bricked volume is the dense volume.
    const Volume back = p.bricked.densified(std::size_t{1} << 30);
    ASSERT_FALSE(back.is_bricked());
    EXPECT_EQ(0, std::memcmp(back.data(), p.dense.data(), p.dense.voxel_count() * sizeof(float)));
  }
}

TEST(BrickedVolume, SharesEveryFlatBrickAndRefusesATooLargeDenseCopy) {
  const Pair p = make_pair({64, 64, 64}, 10.0f);  // a ball of radius 10 in a 64³ box
  std::size_t stored = 0;
  const auto& g = p.bricked.brick_grid();
  for (int z = 0; z < g[2]; ++z)
    for (int y = 0; y < g[1]; ++y)
      for (int x = 0; x < g[0]; ++x) stored += p.bricked.brick_is_shared(x, y, z) ? 0 : 1;
  EXPECT_GT(stored, 0u);
  EXPECT_LE(stored, 64u);  // the ball's reach: at most 4³ of the 8³ bricks
  EXPECT_LT(p.bricked.memory_bytes(), p.dense.memory_bytes() / 4);
  EXPECT_THROW((void)p.bricked.densified(1000), Error);
}

// Every technique draws a bricked volume exactly as its dense copy: the ray caster (gradients, empty
// space), each volume shadow and ambient technique, and the isosurface methods.
TEST(BrickedVolume, RendersExactlyLikeItsDenseCopy) {
  TempDir dir;
  const std::string path = dir.file("blobs.vdb");
  write_grids(path, {blobs()});
  auto render = [&](nlohmann::json j, bool dense) {
    Scene scene = build_scene(j, "");
    EXPECT_TRUE(scene.volumes[0].volume->is_bricked());
    if (dense) scene.volumes[0].volume = std::make_shared<const Volume>(scene.volumes[0].volume->densified(std::size_t{1} << 30));
    return Renderer(std::move(scene)).render().image;
  };
  nlohmann::json base = {{"volumes", {{{"file", path},
                                       {"transfer_function", {{"points", {{0.0, 0.9, 0.6, 0.3, 0.0}, {0.2, 0.9, 0.6, 0.3, 0.1}, {1.0, 0.3, 0.5, 0.9, 0.8}}}}},
                                       {"step", 0.7}}}},
                         {"lights", {{{"type", "directional"}, {"direction", {-0.4, -1.0, -0.3}}}}},
                         {"camera", {{"width", 40}, {"height", 40}}},
                         {"planes", {{{"point", {0, -1, 0}}, {"normal", {0, 1, 0}}, {"size", 20}}}}};
  std::vector<nlohmann::json> scenes;
  for (const char* shadow : {"none", "shadow_map", "deep_shadow_map", "cssm", "ray_traced", "sat_cone", "sampled_cone"}) {
    nlohmann::json j = base;
    j["shadows"] = {{"technique", shadow}, {"resolution", 48}};
    j["ambient"] = {{"technique", std::string(shadow) == "sat_cone" ? "sat_shells" : std::string(shadow) == "ray_traced" ? "sampled_ao" : "none"}};
    scenes.push_back(j);
  }
  for (const char* method : {"points", "raycast", "mesh"}) {
    nlohmann::json j = base;
    j["volumes"][0]["visible"] = false;
    j["isosurfaces"] = nlohmann::json::array({{{"volume", 0}, {"value", 0.3}, {"method", method}}});
    j["shadows"] = {{"technique", "light_pass"}, {"resolution", 48}};
    scenes.push_back(j);
  }
  for (const auto& j : scenes) {
    SCOPED_TRACE(j.dump().substr(0, 0) + j["shadows"]["technique"].get<std::string>() +
                 (j.contains("isosurfaces") ? " isosurface " + j["isosurfaces"][0]["method"].get<std::string>() : ""));
    const Image a = render(j, false), b = render(j, true);
    int lit = 0;
    for (const Rgb& c : b.pixels()) lit += c.r > 0.2f ? 1 : 0;
    EXPECT_GT(lit, 0) << "nothing drawn";
    EXPECT_TRUE(a.pixels() == b.pixels()) << "the bricked volume draws differently from its dense copy";
  }
}

TEST(VdbFile, FogGridLoadsSparseWithEveryVoxelOfTheGrid) {
  TempDir dir;
  const std::string path = dir.file("blobs.vdb");
  const auto grid = blobs();
  write_grids(path, {grid});
  VolumeFileInfo info;
  const Volume v = load_vdb(path, "", &info);
  EXPECT_EQ(info.format, "vdb");
  ASSERT_TRUE(v.is_bricked());
  expect_every_voxel(v, *grid);
  EXPECT_EQ(v.min_value(), 0.0f);
  EXPECT_EQ(v.max_value(), 1.0f);
  // Three balls of 13³ voxels in a box of about 70³: stored bricks only around them.
  EXPECT_LT(v.memory_bytes(), v.voxel_count() * sizeof(float) / 3);
  EXPECT_TRUE(has_note(info, "sparse:")) << "the memory against a dense volume is reported";
  EXPECT_TRUE(has_note(info, "grid 'density': float, fog volume"));
}

TEST(VdbFile, LevelSetInsideIsOneSharedBrickValue) {
  TempDir dir;
  const std::string path = dir.file("sphere.vdb");
  auto ls = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(30.0f, openvdb::Vec3f(2, -1, 4), 0.5f, 3.0f);
  ls->setName("surface");
  write_grids(path, {ls});
  VolumeFileInfo info;
  const Volume v = load_vdb(path, "", &info);
  expect_every_voxel(v, *ls);
  EXPECT_FLOAT_EQ(v.min_value(), -ls->background());
  EXPECT_FLOAT_EQ(v.max_value(), ls->background());
  EXPECT_FLOAT_EQ(v.spacing().x, 0.5f);
  // The centre of the sphere lies in a shared brick holding the inside value.
  const Vec3 c = v.to_voxel({2, -1, 4});
  const int bx = static_cast<int>(c.x) / 8, by = static_cast<int>(c.y) / 8, bz = static_cast<int>(c.z) / 8;
  EXPECT_TRUE(v.brick_is_shared(bx, by, bz));
  EXPECT_FLOAT_EQ(v.value(v.brick_base(bx, by, bz)), -ls->background());
  EXPECT_TRUE(has_note(info, "level set"));
  EXPECT_LT(v.memory_bytes(), v.voxel_count() * sizeof(float));
}

TEST(VdbFile, DoubleGridWithTilesAndPlacement) {
  TempDir dir;
  const std::string path = dir.file("tiles.vdb");
  auto g = openvdb::DoubleGrid::create(-1.0);
  g->setName("pressure");
  g->fill(openvdb::CoordBBox(openvdb::Coord(-64, 0, 0), openvdb::Coord(-1, 127, 127)), 2.5, true);  // tiles
  g->tree().setValueOn(openvdb::Coord(5, 7, 9), 0.25);                                              // a leaf
  g->setTransform(openvdb::math::Transform::createLinearTransform(openvdb::Mat4d(
      0.5, 0.0, 0.0, 0.0, 0.0, 0.25, 0.0, 0.0, 0.0, 0.0, 2.0, 0.0, 10.0, 20.0, 30.0, 1.0)));  // scale (0.5, 0.25, 2), translation (10, 20, 30)
  write_grids(path, {g});
  const Volume v = load_vdb(path);
  expect_every_voxel(v, *g);
  EXPECT_FLOAT_EQ(v.spacing().x, 0.5f);
  EXPECT_FLOAT_EQ(v.spacing().y, 0.25f);
  EXPECT_FLOAT_EQ(v.spacing().z, 2.0f);
  EXPECT_FLOAT_EQ(v.origin().x, 10 - 64 * 0.5f);
  EXPECT_FLOAT_EQ(v.origin().y, 20.0f);
  EXPECT_FLOAT_EQ(v.origin().z, 30.0f);
  EXPECT_LT(v.memory_bytes(), v.voxel_count() * sizeof(float) / 2) << "tiles are shared, not stored";
}

// A sparse grid is neither reordered nor resampled: a rotation or a flip it cannot honour is an Error
// naming the file and the transform, never dropped.
TEST(VdbFile, RotatedOrFlippedTransformIsAnError) {
  TempDir dir;
  const std::string rotated = dir.file("rotated.vdb"), flipped = dir.file("flipped.vdb");
  auto g = blobs();
  auto t = openvdb::math::Transform::createLinearTransform(0.2);
  t->postRotate(0.3, openvdb::math::Z_AXIS);
  g->setTransform(t);
  write_grids(rotated, {g});
  expect_error(rotated, "", {"transform [", "not an axis-aligned positive scale"});
  g->setTransform(openvdb::math::Transform::createLinearTransform(openvdb::Mat4d(
      -0.5, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 1.0)));
  write_grids(flipped, {g});
  expect_error(flipped, "", {"transform [-0.5 0 0", "not an axis-aligned positive scale"});
}

TEST(VdbFile, GridIsChosenByNameOrIndex) {
  TempDir dir;
  const std::string path = dir.file("two.vdb");
  auto temperature = openvdb::FloatGrid::create(0.0f);
  temperature->setName("temperature");
  temperature->tree().setValueOn(openvdb::Coord(1, 2, 3), 300.0f);
  auto velocity = openvdb::Vec3SGrid::create();
  velocity->setName("v");
  velocity->tree().setValueOn(openvdb::Coord(0, 0, 0), openvdb::Vec3s(1, 0, 0));
  write_grids(path, {velocity, temperature, blobs()});
  EXPECT_EQ(load_vdb(path).max_value(), 1.0f) << "'density' is the default";
  EXPECT_EQ(load_vdb(path, "temperature").max_value(), 300.0f);
  EXPECT_EQ(load_vdb(path, "1").max_value(), 300.0f);
  expect_error(path, "pressure", {"no grid 'pressure'", "temperature", "density"});
  expect_error(path, "v", {"vec3s", "expected float or double"});
  expect_error(path, "7", {"no grid '7'"});
}

TEST(VdbFile, BadFilesAreNamed) {
  TempDir dir;
  const std::string empty_grid = dir.file("empty.vdb");
  auto g = openvdb::FloatGrid::create(0.0f);
  g->setName("density");
  write_grids(empty_grid, {g});
  expect_error(empty_grid, "", {"no active voxels"});

  const std::string text = dir.file("text.vdb");
  write_file(text, std::string("not a vdb file at all\n"));
  expect_error(text, "", {"OpenVDB"});

  const std::string good = dir.file("good.vdb");
  write_grids(good, {blobs()});
  const Bytes bytes = read_file(good);
  for (const std::size_t keep : {std::size_t{8}, std::size_t{100}, std::size_t{400}, bytes.size() / 2, bytes.size() - 40}) {
    const std::string cut = dir.file("cut" + std::to_string(keep) + ".vdb");
    write_file(cut, Bytes(bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(keep)));
    SCOPED_TRACE(keep);
    expect_error(cut, "", {});
  }
  expect_error(dir.file("missing.vdb"), "", {"cannot open"});
  EXPECT_NO_THROW(load_vdb(good, "density")) << "the uncut file loads";
}

// Opened directly, a level set shows its surface (the isosurface at 0) and a fog volume shows itself.
TEST(VdbFile, TheAutomaticSceneShowsALevelSetAsItsSurface) {
  TempDir dir;
  const std::string path = dir.file("two.vdb");
  auto ls = openvdb::tools::createLevelSetSphere<openvdb::FloatGrid>(8.0f, openvdb::Vec3f(0, 0, 0), 0.5f, 3.0f);
  ls->setName("surface");
  write_grids(path, {blobs(), ls});
  SceneDataCache cache;
  VolumeLoadOptions o;
  o.grid = "surface";
  const nlohmann::json surface = data_scene({path}, o, cache);
  ASSERT_TRUE(surface.contains("isosurfaces")) << surface.dump();
  EXPECT_EQ(surface["isosurfaces"][0]["volume"], 0);
  EXPECT_EQ(surface["isosurfaces"][0]["value"], 0.0);
  EXPECT_EQ(surface["volumes"][0]["visible"], false);
  EXPECT_TRUE(build_scene(surface, "").volumes[0].volume->level_set());
  const nlohmann::json fog = data_scene({path}, VolumeLoadOptions{}, cache);
  EXPECT_FALSE(fog.contains("isosurfaces"));
  EXPECT_FALSE(fog["volumes"][0].contains("visible"));
}
