// Trajectory readers: the staged GROMACS run in shared/data (XTC, DCD, multi-model PDB, multi-frame XYZ,
// GRO) against the reference values of PROVENANCE.md ("MD trajectory") and against each other; small
// files written here byte by byte (an uncompressed XTC of < 10 atoms, a DCD in both byte orders, 3-frame
// XYZ/GRO/PDB); truncated, lying and mismatched files, which must give a penumbra::Error naming the file
// and the frame; random access; and a mutation loop over a real compressed XTC frame and a DCD.
// tests/python/test_trajectory_oracle.py compares the same readers with MDAnalysis.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "penumbra/core/error.h"
#include "penumbra/data/io/trajectory_io.h"
#include "shared_data.h"
#include "test_volume_io_util.h"
#include "trajectory_test_util.h"

using namespace penumbra;
using namespace penumbra::test;

namespace {

const std::string kData = shared_data_dir();

const std::string kXtc = kData + "/md_1tii_chainD.xtc";
const std::string kDcd = kData + "/md_1tii_chainD_20frames.dcd";
const std::string kPdb = kData + "/md_1tii_chainD_20frames.pdb.gz";
const std::string kXyz = kData + "/md_1tii_chainD_20frames.xyz.gz";
const std::string kGro = kData + "/md_1tii_chainD.gro";
constexpr std::size_t kAtoms = 18182;

TrajectoryFrame frame(TrajectoryReader& r, std::size_t k) {
  TrajectoryFrame f;
  r.read_frame(k, f);
  return f;
}

void expect_near3(Vec3 p, float x, float y, float z, float tol) {
  EXPECT_NEAR(p.x, x, tol);
  EXPECT_NEAR(p.y, y, tol);
  EXPECT_NEAR(p.z, z, tol);
}

// ------------------------------------------------------------------------------ byte-level writers

void put_be32(Bytes& b, std::uint32_t v) {
  for (int s = 24; s >= 0; s -= 8) b.push_back(static_cast<std::uint8_t>(v >> s));
}
void put_be_float(Bytes& b, float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, 4);
  put_be32(b, u);
}

// An XTC of natoms ≤ 9 (stored as plain floats, nm): frame k has atom i at (i + k, 2i, -i) / 10 nm.
Bytes small_xtc(int natoms, int frames) {
  Bytes b;
  for (int k = 0; k < frames; ++k) {
    put_be32(b, 1995);
    put_be32(b, static_cast<std::uint32_t>(natoms));
    put_be32(b, static_cast<std::uint32_t>(10 * k));       // step
    put_be_float(b, 0.5f * static_cast<float>(k));        // time, ps
    const float box[9] = {3, 0, 0, 0, 3, 0, 1.5f, 1.5f, 2.1213203f};  // a = b = c = 3 nm, 60/60/90
    for (float v : box) put_be_float(b, v);
    put_be32(b, static_cast<std::uint32_t>(natoms));
    for (int i = 0; i < natoms; ++i) {
      put_be_float(b, static_cast<float>(i + k) / 10);
      put_be_float(b, static_cast<float>(2 * i) / 10);
      put_be_float(b, static_cast<float>(-i) / 10);
    }
  }
  return b;
}

// A CHARMM DCD (4-byte markers) of 3 atoms, frame k: atom i at (i, k, i·k) Å; unit cell stored as
// (A, cos γ, B, cos β, cos α, C) = (10, 0, 20, 0, 0.5, 30): α = 60°, β = γ = 90°.
Bytes small_dcd(int frames, int nset, bool big_endian) {
  Bytes b;
  const auto i32 = [&](std::int32_t v) {
    const Bytes x = to_bytes(std::vector<std::int32_t>{v}, big_endian);
    b.insert(b.end(), x.begin(), x.end());
  };
  const auto f32 = [&](float v) {
    const Bytes x = to_bytes(std::vector<float>{v}, big_endian);
    b.insert(b.end(), x.begin(), x.end());
  };
  const auto f64 = [&](double v) {
    const Bytes x = to_bytes(std::vector<double>{v}, big_endian);
    b.insert(b.end(), x.begin(), x.end());
  };
  i32(84);
  b.insert(b.end(), {'C', 'O', 'R', 'D'});
  std::int32_t icntrl[20] = {nset, 50, 10, 0, 0, 0, 0, 0, 0, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 24};
  for (int i = 0; i < 20; ++i) {
    if (i == 9) f32(0.5f / 0.04888821f);  // DELTA: 0.5 ps in AKMA time units
    else i32(icntrl[i]);
  }
  i32(84);
  i32(84);
  i32(1);
  std::string title = "tiny DCD written by test_trajectory_io";
  title.resize(80, ' ');
  b.insert(b.end(), title.begin(), title.end());
  i32(84);
  i32(4), i32(3), i32(4);
  for (int k = 0; k < frames; ++k) {
    i32(48);
    for (double v : {10.0, 0.0, 20.0, 0.0, 0.5, 30.0}) f64(v);
    i32(48);
    for (int d = 0; d < 3; ++d) {
      i32(12);
      for (int i = 0; i < 3; ++i) f32(static_cast<float>(d == 0 ? i : d == 1 ? k : i * k));
      i32(12);
    }
  }
  return b;
}

std::string xyz_text(int frames, int atoms, int odd_frame = -1) {
  std::string s;
  for (int k = 0; k < frames; ++k) {
    const int n = k == odd_frame ? atoms + 1 : atoms;
    s += std::to_string(n) + "\nframe " + std::to_string(k) + "\n";
    for (int i = 0; i < n; ++i) s += "C " + std::to_string(i) + ".25 " + std::to_string(k) + ".5 -" + std::to_string(i + k) + ".125\n";
  }
  return s;
}

std::string gro_text(int frames, int atoms) {
  std::string s;
  char line[128];
  for (int k = 0; k < frames; ++k) {
    std::snprintf(line, sizeof line, "test t= %.5f step= %d\n%5d\n", 0.2 * k, 100 * k, atoms);
    s += line;
    for (int i = 0; i < atoms; ++i) {
      std::snprintf(line, sizeof line, "%5d%-5s%5s%5d%8.3f%8.3f%8.3f\n", 1, "SOL", "OW", i + 1, 0.1 * i, 0.2 * k, -0.05 * i);
      s += line;
    }
    s += k == 1 ? "   3.00000   3.00000   2.12132   0.00000   0.00000   0.00000   0.00000   1.50000   1.50000\n"
                : "   3.00000   4.00000   5.00000\n";
  }
  return s;
}

std::string pdb_text(int frames, int atoms, bool models = true) {
  std::string s = "TITLE     test\nCRYST1   30.000   40.000   50.000  90.00  90.00 120.00 P 1           1\n";
  char line[128];
  for (int k = 0; k < frames; ++k) {
    if (models) {
      std::snprintf(line, sizeof line, "MODEL     %4d\n", k + 1);
      s += line;
    }
    for (int i = 0; i < atoms; ++i) {
      std::snprintf(line, sizeof line, "ATOM  %5d  CA  ALA A%4d    %8.3f%8.3f%8.3f  1.00  0.00           C\n", i + 1, i + 1,
                    1.5 * i, -2.0 * k, 0.001 * i);
      s += line;
    }
    if (models) s += "ENDMDL\n";
  }
  return s + "END\n";
}

}  // namespace

// ------------------------------------------------------------------------------ the staged run

TEST(TrajectoryStaged, XtcMatchesProvenance) {
  SKIP_WITHOUT_SHARED_DATA("md_1tii_chainD.xtc");
  auto r = open_trajectory(kXtc, kAtoms);
  EXPECT_EQ(r->format(), "xtc");
  ASSERT_EQ(r->frame_count(), 151u);
  EXPECT_EQ(r->atom_count(), kAtoms);
  const TrajectoryFrame f0 = frame(*r, 0), f150 = frame(*r, 150);
  expect_near3(f0.positions[0], 32.11f, 43.68f, 12.22f, 0.005f);
  expect_near3(f0.positions[1], 31.24f, 44.11f, 12.51f, 0.005f);
  expect_near3(f0.positions[18181], 56.68f, 58.63f, 4.58f, 0.005f);
  expect_near3(f150.positions[0], 31.04f, 43.72f, 12.54f, 0.005f);
  expect_near3(f150.positions[1], 30.04f, 43.72f, 12.44f, 0.005f);
  expect_near3(f150.positions[18181], 58.42f, 60.64f, 4.28f, 0.005f);
  EXPECT_NEAR(f0.time_ps, 0.0, 1e-6);
  EXPECT_NEAR(f150.time_ps, 30.0, 1e-4);
  EXPECT_EQ(f150.step, 15000);
  ASSERT_TRUE(f0.has_box && f150.has_box);
  const float want0[6] = {64.008f, 64.008f, 64.008f, 60, 60, 90}, want150[6] = {63.712f, 63.712f, 63.712f, 60, 60, 90};
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_NEAR(f0.box[i], want0[i], 1e-3) << i;
    EXPECT_NEAR(f150.box[i], want150[i], 1e-3) << i;
  }
  // Frame-0 bounding box of all atoms (PROVENANCE.md).
  Vec3 lo{1e9f, 1e9f, 1e9f}, hi{-1e9f, -1e9f, -1e9f};
  for (const Vec3& p : f0.positions)
    for (int d = 0; d < 3; ++d) {
      lo[d] = std::min(lo[d], p[d]);
      hi[d] = std::max(hi[d], p[d]);
    }
  expect_near3(lo, 15.34f, 15.20f, -20.86f, 0.005f);
  expect_near3(hi, 80.82f, 80.62f, 66.68f, 0.005f);
  // Times every 0.2 ps, steps every 100; the 0.01 Å grid of precision 1000/nm.
  for (std::size_t k = 0; k < r->frame_count(); k += 10) {
    const TrajectoryFrame f = frame(*r, k);
    EXPECT_NEAR(f.time_ps, 0.2 * static_cast<double>(k), 1e-4);
    EXPECT_EQ(f.step, static_cast<std::int64_t>(100 * k));
    for (std::size_t i = 0; i < f.positions.size(); i += 997)
      EXPECT_NEAR(f.positions[i].x * 100, std::round(f.positions[i].x * 100), 1e-2) << k << " " << i;
  }
  EXPECT_LT(r->memory_bytes(), 1u << 20);  // an index and one compressed frame, not the trajectory
}

TEST(TrajectoryStaged, DcdPdbXyzGroAgreeWithXtc) {
  SKIP_WITHOUT_SHARED_DATA("md_1tii_chainD_20frames.dcd");
  SKIP_WITHOUT_SHARED_DATA("md_1tii_chainD_20frames.pdb.gz");
  SKIP_WITHOUT_SHARED_DATA("md_1tii_chainD_20frames.xyz.gz");
  auto xtc = open_trajectory(kXtc);
  auto dcd = open_trajectory(kDcd, kAtoms);
  auto pdb = open_trajectory(kPdb, kAtoms);
  auto xyz = open_trajectory(kXyz, kAtoms);
  EXPECT_EQ(dcd->format(), "dcd");
  EXPECT_EQ(pdb->format(), "pdb");
  EXPECT_EQ(xyz->format(), "xyz");
  for (auto* r : {dcd.get(), pdb.get(), xyz.get()}) {
    EXPECT_EQ(r->frame_count(), 20u) << r->format();
    EXPECT_EQ(r->atom_count(), kAtoms) << r->format();
  }
  float d_dcd = 0, d_pdb = 0, d_xyz = 0;
  const TrajectoryFrame x0 = frame(*xtc, 0);
  for (std::size_t k = 0; k < 20; ++k) {
    const TrajectoryFrame x = frame(*xtc, k), d = frame(*dcd, k), p = frame(*pdb, k), y = frame(*xyz, k);
    d_dcd = std::max(d_dcd, max_diff(x.positions, d.positions));
    d_pdb = std::max(d_pdb, max_diff(x.positions, p.positions));
    d_xyz = std::max(d_xyz, max_diff(x.positions, y.positions));
    // DCD: time from DELTA·NSAVC (0.2 ps), the unit cell identical to the XTC's.
    EXPECT_NEAR(d.time_ps, x.time_ps, 1e-5) << k;
    EXPECT_EQ(d.step, x.step) << k;
    ASSERT_TRUE(d.has_box);
    for (std::size_t i = 0; i < 6; ++i) EXPECT_EQ(d.box[i], x.box[i]) << k << " " << i;
    // PDB: one CRYST1 before MODEL 1, the frame-0 cell, for every model; XYZ has none.
    ASSERT_TRUE(p.has_box);
    for (std::size_t i = 0; i < 6; ++i) EXPECT_NEAR(p.box[i], x0.box[i], 1e-3) << k << " " << i;
    EXPECT_FALSE(y.has_box);
    EXPECT_EQ(p.time_ps, static_cast<double>(k));
  }
  EXPECT_EQ(d_dcd, 0.0f);
  EXPECT_LE(d_pdb, 2e-5f);
  EXPECT_LE(d_xyz, 1e-5f);

  SKIP_WITHOUT_SHARED_DATA("md_1tii_chainD.gro");
  auto gro = open_trajectory(kGro, kAtoms);
  ASSERT_EQ(gro->frame_count(), 1u);
  const TrajectoryFrame g = frame(*gro, 0);
  EXPECT_LE(max_diff(x0.positions, g.positions), 2e-5f);
  EXPECT_EQ(g.time_ps, 0.0);
  ASSERT_TRUE(g.has_box);
  for (std::size_t i = 0; i < 6; ++i) EXPECT_NEAR(g.box[i], x0.box[i], 1e-3) << i;
}

TEST(TrajectoryStaged, RandomAccessEqualsReadingInOrder) {
  SKIP_WITHOUT_SHARED_DATA("md_1tii_chainD_20frames.pdb.gz");
  for (const std::string& path : {kXtc, kDcd, kPdb, kXyz}) {
    auto in_order = open_trajectory(path);
    std::vector<TrajectoryFrame> frames;
    for (std::size_t k = 0; k < 8; ++k) frames.push_back(frame(*in_order, k));
    auto r = open_trajectory(path);
    const TrajectoryFrame f7 = frame(*r, 7), f3 = frame(*r, 3);
    EXPECT_EQ(max_diff(f7.positions, frames[7].positions), 0.0f) << path;
    EXPECT_EQ(max_diff(f3.positions, frames[3].positions), 0.0f) << path;
    EXPECT_EQ(f3.time_ps, frames[3].time_ps) << path;
    EXPECT_EQ(f7.box, frames[7].box) << path;
    EXPECT_GT(max_diff(f3.positions, f7.positions), 0.1f) << path;  // the frames do differ
  }
}

TEST(TrajectoryStaged, ListOfFilesAndTopologyMismatch) {
  SKIP_WITHOUT_SHARED_DATA("md_1tii_chainD_20frames.dcd");
  auto list = open_trajectory(std::vector<std::string>{kDcd, kXyz}, kAtoms);
  EXPECT_EQ(list->frame_count(), 40u);
  EXPECT_EQ(list->format(), "dcd+xyz");
  auto xtc = open_trajectory(kXtc);
  const TrajectoryFrame a = frame(*list, 25), b = frame(*xtc, 5), c = frame(*list, 5);
  EXPECT_LE(max_diff(a.positions, b.positions), 1e-5f);
  EXPECT_EQ(a.time_ps, 25.0);  // XYZ stores no time: the index in the list
  EXPECT_NEAR(c.time_ps, 1.0, 1e-5);
  // A topology of another size: Error naming the file, the frame, the counts found and expected.
  for (const std::string& path : {kXtc, kDcd, kPdb, kXyz, kGro})
    EXPECT_ERROR_NAMES(error_of(path, kAtoms - 1), path, "frame 0", "18182", "18181");
}

// ------------------------------------------------------------------------------ small files

TEST(TrajectorySmall, UncompressedXtc) {
  TempDir dir;
  const std::string path = dir.file("four.xtc");
  write_file(path, small_xtc(4, 3));
  auto r = open_trajectory(path, 4);
  ASSERT_EQ(r->frame_count(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {
    const TrajectoryFrame f = frame(*r, k);
    EXPECT_EQ(f.time_ps, 0.5 * static_cast<double>(k));
    EXPECT_EQ(f.step, static_cast<std::int64_t>(10 * k));
    for (std::size_t i = 0; i < 4; ++i)
      expect_near3(f.positions[i], static_cast<float>(i + k), 2.0f * static_cast<float>(i), -static_cast<float>(i), 1e-5f);
    ASSERT_TRUE(f.has_box);
    const float want[6] = {30, 30, 30, 60, 60, 90};
    for (std::size_t i = 0; i < 6; ++i) EXPECT_NEAR(f.box[i], want[i], 1e-4) << i;
  }
  // Cut inside frame 2; a header claiming 2³¹−1 atoms; a wrong magic number.
  Bytes bytes = small_xtc(4, 3);
  write_file(path, Bytes(bytes.begin(), bytes.end() - 7));
  EXPECT_ERROR_NAMES(error_of(path), path, "frame 2", "truncated");
  bytes = small_xtc(4, 1);
  for (std::size_t at : {4u, 52u}) bytes[at] = 0x7f, bytes[at + 1] = bytes[at + 2] = bytes[at + 3] = 0xff;
  write_file(path, bytes);
  EXPECT_ERROR_NAMES(error_of(path), path, "frame 0");
  bytes = small_xtc(4, 2);
  bytes[small_xtc(4, 1).size() + 3] = 0;
  write_file(path, bytes);
  EXPECT_ERROR_NAMES(error_of(path), path, "frame 1", "1995");
  write_file(path, small_xtc(4, 2));
  EXPECT_ERROR_NAMES(error_of(path, 5), path, "frame 0", "4", "5");
}

TEST(TrajectorySmall, DcdBothByteOrders) {
  TempDir dir;
  for (bool big : {false, true}) {
    const std::string path = dir.file(big ? "be.dcd" : "le.dcd");
    write_file(path, small_dcd(2, 2, big));
    auto r = open_trajectory(path, 3);
    ASSERT_EQ(r->frame_count(), 2u);
    ASSERT_EQ(r->atom_count(), 3u);
    for (std::size_t k = 0; k < 2; ++k) {
      const TrajectoryFrame f = frame(*r, k);
      for (std::size_t i = 0; i < 3; ++i)
        expect_near3(f.positions[i], static_cast<float>(i), static_cast<float>(k), static_cast<float>(i * k), 0);
      // dt = DELTA·NSAVC = 10 × 0.5 ps; ISTART 50 = frame 5 of that spacing.
      EXPECT_NEAR(f.time_ps, (static_cast<double>(k) + 5) * 5.0, 1e-4);
      EXPECT_EQ(f.step, static_cast<std::int64_t>(50 + 10 * k));
      ASSERT_TRUE(f.has_box);
      const float want[6] = {10, 20, 30, 60, 90, 90};
      for (std::size_t i = 0; i < 6; ++i) EXPECT_NEAR(f.box[i], want[i], 1e-4) << i;
    }
  }
  const std::string path = dir.file("bad.dcd");
  const Bytes good = small_dcd(3, 3, false);
  write_file(path, Bytes(good.begin(), good.end() - 20));  // cut inside frame 2
  EXPECT_ERROR_NAMES(error_of(path), path, "frame 2", "truncated");
  write_file(path, small_dcd(2, 5, false));  // NSET says 5, the file holds 2
  EXPECT_ERROR_NAMES(error_of(path), path, "frame 2", "NSET");
  write_file(path, small_dcd(3, 2, false));  // NSET says 2, the file holds 3
  EXPECT_ERROR_NAMES(error_of(path), path, "frame 2", "NSET");
  write_file(path, small_dcd(2, 2, false));
  EXPECT_ERROR_NAMES(error_of(path, 4), path, "frame 0", "3", "4");
  Bytes lying = small_dcd(2, 2, false);
  const std::size_t natom_at = lying.size() - 2 * (56 + 3 * 20) - 8;  // NATOM: before the two frames and its end marker
  lying[natom_at + 3] = 0x40;                                            // 2³⁰ + 3 atoms
  write_file(path, lying);
  EXPECT_ERROR_NAMES(error_of(path), path, "frame 0", "truncated");
  Bytes corrupt = small_dcd(2, 2, false);
  corrupt[corrupt.size() - 4] = 13;  // the closing marker of frame 1's Z record
  write_file(path, corrupt);
  EXPECT_ERROR_NAMES(error_of(path), path, "frame 1", "Z");
}

TEST(TrajectorySmall, TextFormats) {
  TempDir dir;
  const std::string xyz = dir.file("t.xyz"), gro = dir.file("t.gro"), pdb = dir.file("t.pdb"), single = dir.file("one.pdb");
  write_file(xyz, xyz_text(3, 4));
  write_file(dir.file("t.xyz.gz"), gzip(read_file(xyz)));
  write_file(gro, gro_text(3, 4));
  write_file(pdb, pdb_text(3, 4));
  write_file(single, pdb_text(1, 4, false));
  for (const std::string& path : {xyz, dir.file("t.xyz.gz")}) {
    auto r = open_trajectory(path, 4);
    ASSERT_EQ(r->frame_count(), 3u);
    const TrajectoryFrame f = frame(*r, 2);
    expect_near3(f.positions[3], 3.25f, 2.5f, -5.125f, 0);
    EXPECT_EQ(f.time_ps, 2.0);
    EXPECT_FALSE(f.has_box);
  }
  auto g = open_trajectory(gro, 4);
  ASSERT_EQ(g->frame_count(), 3u);
  const TrajectoryFrame g1 = frame(*g, 1), g2 = frame(*g, 2);
  expect_near3(g2.positions[3], 3.0f, 4.0f, -1.5f, 1e-5f);
  EXPECT_NEAR(g2.time_ps, 0.4, 1e-9);
  EXPECT_EQ(g2.step, 200);
  const float want_ortho[6] = {30, 40, 50, 90, 90, 90}, want_tric[6] = {30, 30, 30, 60, 60, 90};
  for (std::size_t i = 0; i < 6; ++i) {
    EXPECT_NEAR(g2.box[i], want_ortho[i], 1e-4) << i;
    EXPECT_NEAR(g1.box[i], want_tric[i], 1e-3) << i;
  }
  auto p = open_trajectory(pdb, 4);
  ASSERT_EQ(p->frame_count(), 3u);
  const TrajectoryFrame p2 = frame(*p, 2);
  expect_near3(p2.positions[3], 4.5f, -4.0f, 0.003f, 1e-6f);
  const float want_pdb[6] = {30, 40, 50, 90, 90, 120};
  for (std::size_t i = 0; i < 6; ++i) EXPECT_EQ(p2.box[i], want_pdb[i]) << i;
  EXPECT_EQ(open_trajectory(single)->frame_count(), 1u);
  // Random access in every text reader, plain and gzip: 2, 0, 1, 2 equal reading in order.
  for (const std::string& path : {xyz, dir.file("t.xyz.gz"), gro, pdb}) {
    auto in_order = open_trajectory(path), any = open_trajectory(path);
    std::vector<TrajectoryFrame> frames;
    for (std::size_t k = 0; k < 3; ++k) frames.push_back(frame(*in_order, k));
    for (std::size_t k : {2u, 0u, 1u, 2u}) {
      const TrajectoryFrame f = frame(*any, k);
      EXPECT_EQ(max_diff(f.positions, frames[k].positions), 0.0f) << path << " " << k;
      EXPECT_EQ(f.time_ps, frames[k].time_ps) << path << " " << k;
    }
  }

  // Truncated in the last frame, a frame with another atom count, a topology of another size.
  const auto cut = [&](const std::string& path, const std::string& text, std::size_t drop) {
    write_file(path, text.substr(0, text.size() - drop));
  };
  cut(xyz, xyz_text(3, 4), 30);
  EXPECT_ERROR_NAMES(error_of(xyz), xyz, "frame 2", "truncated");
  cut(gro, gro_text(3, 4), 40);
  EXPECT_ERROR_NAMES(error_of(gro), gro, "frame 2", "truncated");
  cut(pdb, pdb_text(3, 4), 20);
  EXPECT_ERROR_NAMES(error_of(pdb), pdb, "frame 2");
  const std::string big = pdb_text(3, 400);
  const Bytes gz = gzip(Bytes(big.begin(), big.end()));
  write_file(dir.file("cut.pdb.gz"), Bytes(gz.begin(), gz.begin() + static_cast<std::ptrdiff_t>(gz.size() * 3 / 4)));
  EXPECT_ERROR_NAMES(error_of(dir.file("cut.pdb.gz")), dir.file("cut.pdb.gz"), "frame ", "truncated");
  write_file(xyz, xyz_text(3, 4, 2));
  EXPECT_ERROR_NAMES(error_of(xyz), xyz, "frame 2", "5 atoms", "frame 0 holds 4");
  for (const std::string& path : {dir.file("t.xyz.gz"), pdb, single}) {
    if (path == pdb) write_file(pdb, pdb_text(3, 4));
    EXPECT_ERROR_NAMES(error_of(path, 7), path, "frame 0", "4 atoms", "7");
  }
  write_file(gro, gro_text(3, 4));
  EXPECT_ERROR_NAMES(error_of(gro, 7), gro, "frame 0", "4 atoms", "7");
  // A coordinate that is not a number is found when the frame is read, named with its line.
  std::string bad = xyz_text(3, 4);
  bad.replace(bad.find("C 1.25 1.5"), 10, "C 1.25 x.5");
  write_file(xyz, bad);
  EXPECT_ERROR_NAMES(error_of(xyz), xyz, "frame 1", "line 10");
}

// A real compressed frame (and the small DCD), mutated: every outcome is a frame or an Error.
TEST(TrajectorySmall, MutatedFilesGiveErrorsNotCrashes) {
  TempDir dir;
  Bytes xtc;
  if (std::filesystem::exists(kXtc)) {
    const Bytes whole = read_file(kXtc);
    const std::size_t first = 92 + ((static_cast<std::size_t>(whole[88]) << 24 | static_cast<std::size_t>(whole[89]) << 16 |
                                     static_cast<std::size_t>(whole[90]) << 8 | whole[91]) + 3) / 4 * 4;
    xtc.assign(whole.begin(), whole.begin() + static_cast<std::ptrdiff_t>(first));
  }
  const Bytes dcd = small_dcd(2, 2, false);
  std::mt19937 gen(2024);
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  const auto uniform = [&] { return unit(gen); };
  int errors = 0, frames = 0;
  for (const Bytes* base : std::vector<const Bytes*>{&xtc, &dcd}) {
    if (base->empty()) continue;
    const std::string path = dir.file(base == &xtc ? "m.xtc" : "m.dcd");
    for (int it = 0; it < 300; ++it) {
      Bytes b = *base;
      const int flips = 1 + static_cast<int>(uniform() * 4);
      for (int f = 0; f < flips; ++f) {
        // Half the mutations hit the headers, where the counts and sizes are.
        const std::size_t span = uniform() < 0.5 ? std::min<std::size_t>(b.size(), 120) : b.size();
        b[static_cast<std::size_t>(uniform() * static_cast<float>(span)) % span] ^= static_cast<std::uint8_t>(1 + uniform() * 254);
      }
      if (uniform() < 0.2) b.resize(static_cast<std::size_t>(uniform() * static_cast<float>(b.size())));
      write_file(path, b);
      (error_of(path).empty() ? frames : errors)++;
    }
  }
  EXPECT_GT(errors, 0);
  EXPECT_GT(frames + errors, 0);
}
