// The private sampling helpers: the incremental Halton cursor must reproduce the direct formula.
#include <gtest/gtest.h>

#include "../../src/visibility/sampling.h"

using namespace mirage::vis::detail;

TEST(Sampling, HaltonCursorMatchesDirectEvaluation) {
  RandomizedHalton<5> h(42);
  for (uint64_t start : {uint64_t(0), uint64_t(7), uint64_t(4095), uint64_t(1) << 33}) {
    auto cursor = h.cursor(start);
    for (uint64_t i = start; i < start + 5000; ++i, cursor.next()) {
      auto a = cursor();
      auto b = h(i);
      for (int d = 0; d < 5; ++d) ASSERT_NEAR(a[size_t(d)], b[size_t(d)], 1e-6f) << "index " << i << " dim " << d;
    }
  }
  EXPECT_FLOAT_EQ(radicalInverse(1, 2), 0.5f);
  EXPECT_FLOAT_EQ(radicalInverse(6, 2), 0.375f);
  EXPECT_FLOAT_EQ(radicalInverse(5, 3), 7.0f / 9.0f);
  EXPECT_NEAR(radicalInverse((uint64_t(1) << 40) + 5, 3), radicalInverse<3>((uint64_t(1) << 40) + 5), 1e-6f);
}

TEST(Sampling, SphereDirectionsAreUnitAndBalanced) {
  glm::vec3 sum(0.0f);
  RandomizedHalton<2> h(1);
  for (uint64_t i = 0; i < 10000; ++i) {
    auto u = h(i);
    glm::vec3 d = sphereDirection(u[0], u[1]);
    ASSERT_NEAR(glm::length(d), 1.0f, 1e-5f);
    sum += d;
  }
  EXPECT_LT(glm::length(sum) / 10000.0f, 0.01f);
}
