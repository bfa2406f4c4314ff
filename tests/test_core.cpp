#include <gtest/gtest.h>

#include <cmath>
#include <cstring>

#include "penumbra/core/byte_size.h"
#include "penumbra/core/color.h"
#include "penumbra/core/cutoffs.h"
#include "penumbra/core/math.h"
#include "penumbra/core/error.h"
#include "penumbra/core/rng.h"

using namespace penumbra;

TEST(Math, BoxClipsRay) {
  Box3 b{{-1, -1, -1}, {1, 1, 1}};
  float t0, t1;
  ASSERT_TRUE(b.clip(Ray{{-3, 0, 0}, {1, 0, 0}}, t0, t1));
  EXPECT_FLOAT_EQ(t0, 2.0f);
  EXPECT_FLOAT_EQ(t1, 4.0f);
  EXPECT_FALSE(b.clip(Ray{{-3, 2, 0}, {1, 0, 0}}, t0, t1));
}

#include "penumbra/core/image.h"
#include "penumbra/core/parallel.h"
#include "penumbra/data/volume.h"

// A linear field f = 2x − 3y + 0.5z + 7 (world units) is reproduced exactly by trilinear interpolation,
// and its central-difference gradient is exactly (2, −3, 0.5) away from the border, for every voxel type
// that can hold it and with anisotropic spacing.
TEST(VolumeCore, TrilinearAndGradientAreExactForLinearFields) {
  Volume v(ScalarType::Float32, {9, 7, 5}, {0.5f, 1.0f, 2.0f}, {-1, 0, 3});
  for (int k = 0; k < 5; ++k)
    for (int j = 0; j < 7; ++j)
      for (int i = 0; i < 9; ++i) {
        const Vec3 p = v.origin() + Vec3{static_cast<float>(i) * 0.5f, static_cast<float>(j), static_cast<float>(k) * 2.0f};
        v.set_value(v.index(i, j, k), 2 * p.x - 3 * p.y + 0.5f * p.z + 7);
      }
  v.recompute_range();
  for (float t : {0.13f, 0.5f, 0.77f}) {
    const Vec3 p{-1 + 4 * t, 6 * t, 3 + 8 * t};
    EXPECT_NEAR(v.sample(p), 2 * p.x - 3 * p.y + 0.5f * p.z + 7, 1e-4);
    const Vec3 inner{-1 + 1 + 2 * t, 1 + 4 * t, 3 + 2 + 4 * t};  // at least one voxel from the border
    const Vec3 g = v.gradient(inner);
    EXPECT_NEAR(g.x, 2.0f, 1e-4);
    EXPECT_NEAR(g.y, -3.0f, 1e-4);
    EXPECT_NEAR(g.z, 0.5f, 1e-4);
  }
  // outside the grid, samples clamp to the border voxels
  EXPECT_NEAR(v.sample({-100, 0, 3}), v.value(0, 0, 0), 1e-5);
}

TEST(VolumeCore, RejectsBadDimensionsAndNaN) {
  EXPECT_THROW(Volume(ScalarType::UInt8, {0, 4, 4}), Error);
  EXPECT_THROW(Volume(ScalarType::UInt8, {4, 4, 4}, {0, 1, 1}), Error);
  EXPECT_THROW(checked_voxel_count({1 << 20, 1 << 20, 1 << 20}), Error);
  Volume v(ScalarType::Float32, {2, 2, 2});
  v.set_value(3, std::nanf(""));
  EXPECT_THROW(v.recompute_range(), Error);
}

// A box that moves keeps in place the voxels both places hold: each voxel v of the new grid (any
// dimensions, fewer or more voxels) whose v + by lies in the old grid holds that voxel's value, for
// shifts along every axis and both directions (brute force against a copy); a grid of as many voxels
// stays in the same memory (a resize may move the buffer: AddressSanitizer's realloc always does).
TEST(VolumeCore, MovedVoxelsKeepEveryVoxelBothGridsHold) {
  const std::array<int, 3> d{7, 5, 4};
  int checked = 0;
  for (const std::array<int, 3>& to : std::vector<std::array<int, 3>>{
           {7, 5, 4}, {9, 5, 3}, {4, 7, 4}, {7, 2, 10}, {3, 3, 3}, {140, 1, 1}, {9, 7, 6}, {20, 3, 5}, {7, 5, 11}, {3, 12, 9}})
    for (int bz = -4; bz <= 4; bz += 2)
      for (int by = -5; by <= 5; by += 2)
        for (int bx = -7; bx <= 7; bx += 3) {
          Volume v(ScalarType::UInt16, d);
          for (std::size_t n = 0; n < v.voxel_count(); ++n) v.set_value(n, static_cast<float>(n + 1));
          const Volume before = v;
          const std::byte* storage = v.data();
          v.move_voxels(to, {bx, by, bz});
          ASSERT_EQ(v.dims(), to);
          if (v.voxel_count() == before.voxel_count()) {
            EXPECT_EQ(v.data(), storage);
          }
          for (int k = 0; k < to[2]; ++k)
            for (int j = 0; j < to[1]; ++j)
              for (int i = 0; i < to[0]; ++i) {
                const int si = i + bx, sj = j + by, sk = k + bz;
                if (si < 0 || sj < 0 || sk < 0 || si >= d[0] || sj >= d[1] || sk >= d[2]) continue;
                ++checked;
                ASSERT_EQ(v.value(i, j, k), before.value(si, sj, sk))
                    << to[0] << "x" << to[1] << "x" << to[2] << " by " << bx << "," << by << "," << bz << " at " << i << "," << j << "," << k;
              }
        }
  EXPECT_GT(checked, 9000);
  Volume bricked = Volume::bricked({9, 9, 9}, {1, 1, 1}, {0, 0, 0}, [](const std::array<int, 3>&) { return 0.0f; },
                                   [](const std::array<int, 3>&, float*) {});
  EXPECT_THROW(bricked.move_voxels({9, 9, 9}, {1, 0, 0}), Error);
}

// The bytes a volume owns keep what they hold when they grow or shrink (a buffer large enough for glibc
// to map it by itself, whose pages are then remapped, and a small one), and copy and move as values.
TEST(VolumeCore, VoxelBytesKeepTheirBytesWhenResized) {
  for (const std::size_t size : {std::size_t{1000}, std::size_t{48} << 20}) {
    VoxelBytes b;
    EXPECT_TRUE(b.empty());
    b.resize(size);
    for (std::size_t i = 0; i < size; i += 4093) b.data()[i] = static_cast<std::byte>(i % 251);
    b.resize(size * 2);
    ASSERT_EQ(b.size(), size * 2);
    for (std::size_t i = 0; i < size; i += 4093) ASSERT_EQ(b.data()[i], static_cast<std::byte>(i % 251)) << i;
    b.resize(size / 3);
    for (std::size_t i = 0; i < size / 3; i += 4093) ASSERT_EQ(b.data()[i], static_cast<std::byte>(i % 251)) << i;
    const VoxelBytes copy = b;
    ASSERT_EQ(copy.size(), b.size());
    EXPECT_NE(copy.data(), b.data());
    EXPECT_EQ(std::memcmp(copy.data(), b.data(), b.size()), 0);
    const std::byte* held = b.data();
    VoxelBytes moved = std::move(b);
    EXPECT_EQ(moved.data(), held);
    EXPECT_TRUE(b.empty());  // NOLINT(bugprone-use-after-move): a moved-from buffer is empty
    moved.resize(0);
    EXPECT_TRUE(moved.empty());
  }
}

// The counter-based generator: same keys, same number; different keys, different numbers; roughly
// uniform (χ² over 16 bins at 10^5 draws, critical value 37.7 for 15 degrees of freedom at α = 0.001).
TEST(ByteSize, ParsesWhatUsersWrite) {
  EXPECT_EQ(parse_byte_size("3000000"), 3000000u);
  EXPECT_EQ(parse_byte_size("512M"), 512ull << 20);
  EXPECT_EQ(parse_byte_size("4G"), 4ull << 30);
  EXPECT_EQ(parse_byte_size("4 GiB"), 4ull << 30);
  EXPECT_EQ(parse_byte_size("1.5gb"), 3ull << 29);
  EXPECT_EQ(parse_byte_size("2T"), 2ull << 40);
  EXPECT_EQ(parse_byte_size("64k"), 64ull << 10);
  EXPECT_EQ(parse_byte_size("100 B"), 100u);
  for (const char* bad : {"", "G", "-1G", "0", "4X", "4GX", "1e30", "4 G B", "..", "0.1"}) {
    try {
      parse_byte_size(bad);
      ADD_FAILURE() << "'" << bad << "' parsed";
    } catch (const Error& e) {
      EXPECT_NE(std::string(e.what()).find(std::string("'") + bad + "'"), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(byte_size_string(100), "100 B");
  EXPECT_EQ(byte_size_string(3ull << 29), "1.5 GiB");
  EXPECT_EQ(byte_size_string(512ull << 20), "512 MiB");
}

TEST(Rng, CounterBasedAndUniform) {
  EXPECT_EQ(uniform_float(1, 2, 3), uniform_float(1, 2, 3));
  EXPECT_NE(uniform_float(1, 2, 3), uniform_float(1, 2, 4));
  EXPECT_NE(uniform_float(1, 2, 3), uniform_float(2, 2, 3));
  const RandomStream s(5, 6);
  int bins[16] = {};
  const int n = 100000;
  for (int i = 0; i < n; ++i) {
    const float u = s(static_cast<std::uint64_t>(i));
    ASSERT_GE(u, 0.0f);
    ASSERT_LT(u, 1.0f);
    ++bins[static_cast<int>(u * 16)];
  }
  double chi2 = 0;
  for (int b : bins) chi2 += (b - n / 16.0) * (b - n / 16.0) / (n / 16.0);
  EXPECT_LT(chi2, 37.7);
}

TEST(ImageCore, CompareAndMontage) {
  Image a(4, 3, Rgb(0.5f)), b(4, 3, Rgb(0.5f));
  EXPECT_EQ(compare_images(a, b).rmse, 0.0);
  b.at(1, 1) = Rgb(0.6f);
  const ImageDifference d = compare_images(a, b);
  EXPECT_NEAR(d.rmse, std::sqrt(3 * 0.01 / 36.0), 1e-6);
  EXPECT_NEAR(d.psnr, 20 * std::log10(1 / d.rmse), 1e-9);
  EXPECT_THROW(compare_images(a, Image(3, 3)), Error);
  const Image m = montage({&a, &b});
  EXPECT_EQ(m.width(), 4 + 4 + 4);
  EXPECT_EQ(m.at(5, 1).r, 1.0f);       // the white gap
  EXPECT_EQ(m.at(8 + 1, 1).r, 0.6f);   // b's changed pixel, after a and the gap
}

// The shadow-ray cut-off as an optical depth is the same cut-off as a transmittance.
TEST(Cutoffs, OpaqueDepthIsMinusLogOfShadowOpaque) {
  EXPECT_NEAR(kOpaqueDepth, -std::log(static_cast<double>(kShadowOpaque)), 1e-12);
}

// The table-driven sRGB byte is exactly the pow formula's, at every step and its neighbours and on a
// dense sweep (what the PNG writer and the engine's sRGB8 buffers rely on).
TEST(ColorCore, SrgbByteTableIsExactlyThePowFormula) {
  auto reference = [](float v) { return static_cast<int>(std::lround(penumbra::linear_to_srgb(v) * 255.0f)); };
  int checked = 0;
  for (int i = 0; i <= 2000000; ++i) {
    const float v = static_cast<float>(i) / 2000000.0f;
    ASSERT_EQ(static_cast<int>(penumbra::linear_to_srgb8(v)), reference(v)) << v;
    ++checked;
  }
  for (int k = 0; k < 256; ++k) {  // around each step: the smallest float reaching byte k, and its predecessor
    float lo = 0, hi = 1;
    for (int it = 0; it < 60; ++it) {
      const float mid = 0.5f * (lo + hi);
      (reference(mid) >= k ? hi : lo) = mid;
    }
    for (float v : {std::nextafter(hi, 0.0f), hi, std::nextafter(hi, 2.0f)}) EXPECT_EQ(static_cast<int>(penumbra::linear_to_srgb8(v)), reference(v)) << v;
  }
  EXPECT_EQ(penumbra::linear_to_srgb8(-1.0f), 0);
  EXPECT_EQ(penumbra::linear_to_srgb8(2.0f), 255);
  EXPECT_EQ(penumbra::linear_to_srgb8(std::nanf("")), 0);
  EXPECT_GT(checked, 0);
}
