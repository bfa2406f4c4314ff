// The spheres' spatial order (geometry/sphere_order.h): a permutation with the spheres copied in it,
// near neighbours brought together when the set scatters them, the set's own order kept when it is
// already spatial, and prefixes and carried orders that stay what they claim.
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <random>

#include "penumbra/data/particles.h"
#include "penumbra/geometry/sphere_order.h"

namespace penumbra {
namespace {

// The mean distance from each centre to the next one in the order.
double mean_step(const std::vector<Sphere>& spheres) {
  double sum = 0;
  for (std::size_t k = 0; k + 1 < spheres.size(); ++k) sum += length(spheres[k + 1].center - spheres[k].center);
  return sum / static_cast<double>(spheres.size() - 1);
}

void expect_permutation_with_copies(const SphereOrder& order, const ParticleSet& set) {
  ASSERT_EQ(order.ids.size(), set.size());
  ASSERT_EQ(order.spheres.size(), set.size());
  std::vector<bool> seen(set.size(), false);
  for (std::size_t k = 0; k < order.size(); ++k) {
    ASSERT_LT(order.ids[k], set.size());
    ASSERT_FALSE(seen[order.ids[k]]) << "sphere " << order.ids[k] << " twice";
    seen[order.ids[k]] = true;
    const Sphere& s = set.spheres[order.ids[k]];
    ASSERT_TRUE(order.spheres[k].center.x == s.center.x && order.spheres[k].center.y == s.center.y &&
                order.spheres[k].center.z == s.center.z && order.spheres[k].radius == s.radius);
  }
}

// 40³ spheres on a grid, written row by row (spatial already) and shuffled.
ParticleSet grid_spheres(bool shuffled) {
  ParticleSet set;
  for (int z = 0; z < 40; ++z)
    for (int y = 0; y < 40; ++y)
      for (int x = 0; x < 40; ++x) set.spheres.push_back({{static_cast<float>(x), static_cast<float>(y), static_cast<float>(z)}, 0.4f});
  if (shuffled) std::shuffle(set.spheres.begin(), set.spheres.end(), std::mt19937(3));
  set.colors.assign(set.size(), 0);
  return set;
}

TEST(SphereOrder, AScatteredSetIsBroughtIntoAZOrder) {
  const ParticleSet set = grid_spheres(true);
  const SphereOrder order = spatial_order(set);
  expect_permutation_with_copies(order, set);
  // shuffled, the next centre is ~half the box away; in the Z-order of ~1.6 spheres a cell, mostly a
  // neighbour's (the curve's jumps between blocks add a little)
  EXPECT_GT(mean_step(set.spheres), 15.0);
  EXPECT_LT(mean_step(order.spheres), 2.5);
}

TEST(SphereOrder, ASetAlreadyInASpatialOrderKeepsIt) {
  const ParticleSet set = grid_spheres(false);
  const SphereOrder order = spatial_order(set);
  expect_permutation_with_copies(order, set);
  for (std::size_t k = 0; k < order.size(); ++k) ASSERT_EQ(order.ids[k], k);
  // and a set too small or flat to have a box: no division by a zero volume
  ParticleSet line;
  for (int i = 0; i < 10; ++i) line.spheres.push_back({{static_cast<float>((i * 7) % 10), 0, 0}, 0.1f});
  expect_permutation_with_copies(spatial_order(line), line);
  expect_permutation_with_copies(spatial_order(ParticleSet{}), ParticleSet{});
}

TEST(SphereOrder, APrefixKeepsTheOrderOfItsSpheresAndACarriedOrderTakesTheNewPositions) {
  const ParticleSet set = grid_spheres(true);
  const SphereOrder order = spatial_order(set);
  const std::size_t count = set.size() / 3;
  const SphereOrder prefix = prefix_order(order, count);
  ParticleSet first;
  first.spheres.assign(set.spheres.begin(), set.spheres.begin() + static_cast<std::ptrdiff_t>(count));
  expect_permutation_with_copies(prefix, first);
  std::vector<std::uint32_t> expected;
  for (const std::uint32_t id : order.ids)
    if (id < count) expected.push_back(id);
  EXPECT_EQ(prefix.ids, expected);

  ParticleSet moved = set;
  for (Sphere& s : moved.spheres) s.center = s.center + Vec3{0.1f, -0.2f, 0.05f};
  SphereOrder carried = order;
  carry_order(carried, moved);
  EXPECT_EQ(carried.ids, order.ids);
  expect_permutation_with_copies(carried, moved);
}

}  // namespace
}  // namespace penumbra
