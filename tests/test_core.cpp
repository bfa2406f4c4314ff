#include <gtest/gtest.h>

#include "penumbra/core/math.h"
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
