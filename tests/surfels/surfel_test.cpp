// Surfel packing (exact tests on hand-made values) and the kd-tree against brute force.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "../../src/surfels/kdtree.h"
#include "mirage/surfels/point_cloud.h"
#include "mirage/surfels/surfel.h"

using namespace mirage;
using namespace mirage::surfels;

TEST(SurfelPacking, PositionErrorWithinHalfAStep) {
  Bounds box;
  box.add(glm::vec3(-3.0f, 0.0f, 10.0f));
  box.add(glm::vec3(5.0f, 2.0f, 11.0f));
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  for (int i = 0; i < 1000; ++i) {
    glm::vec3 p = box.min + glm::vec3(u(rng), u(rng), u(rng)) * box.extent();
    glm::vec3 q = surfelPosition(box, packSurfel(box, p, {0, 0, 1}, 0));
    glm::vec3 step = box.extent() / float((1u << MIRAGE_SURFEL_POSITION_BITS) - 1u);
    for (int a = 0; a < 3; ++a) EXPECT_LE(std::abs(p[a] - q[a]), step[a] * 0.5f + 1e-6f);
  }
  // The corners are represented exactly.
  EXPECT_EQ(surfelPosition(box, packSurfel(box, box.min, {0, 0, 1}, 0)), box.min);
  EXPECT_EQ(surfelPosition(box, packSurfel(box, box.max, {0, 0, 1}, 0)), box.max);
}

TEST(SurfelPacking, OctahedralNormalsAndColour) {
  std::mt19937 rng(3);
  std::normal_distribution<float> g;
  for (int i = 0; i < 1000; ++i) {
    glm::vec3 n = glm::normalize(glm::vec3(g(rng), g(rng), g(rng)));
    glm::vec3 d = decodeOctahedral(encodeOctahedral(n));
    EXPECT_LT(glm::length(glm::cross(n, d)), 2e-4f) << i; // sin of the angle
    EXPECT_GT(glm::dot(n, d), 0.0f);
  }
  for (glm::vec3 n : {glm::vec3(0, 0, 1), glm::vec3(0, 0, -1), glm::vec3(1, 0, 0), glm::vec3(0, -1, 0)})
    EXPECT_GT(glm::dot(n, decodeOctahedral(encodeOctahedral(n))), 0.99999f);
  Bounds box;
  box.add(glm::vec3(0.0f));
  box.add(glm::vec3(1.0f));
  EXPECT_EQ(packSurfel(box, glm::vec3(0.5f), {0, 1, 0}, 0x80402010u).color, 0x80402010u);
}

TEST(SurfelKdTree, MatchesBruteForce) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  std::vector<glm::vec3> pts(3000);
  for (auto& p : pts) p = {u(rng), u(rng), u(rng) * 0.1f};
  pts[10] = pts[20]; // duplicates must not confuse the queries
  KdTree tree(pts);
  for (int q = 0; q < 50; ++q) {
    glm::vec3 c(u(rng), u(rng), 0.0f);
    float r = 0.05f + 0.2f * std::abs(u(rng));
    size_t expected = 0, got = 0;
    for (const auto& p : pts) expected += glm::dot(p - c, p - c) < r * r;
    tree.forEachWithin(c, r, [&](uint32_t, float) { ++got; });
    EXPECT_EQ(got, expected);
    uint32_t self = uint32_t(q * 7);
    float best = INFINITY;
    for (uint32_t i = 0; i < pts.size(); ++i)
      if (i != self) best = std::min(best, glm::dot(pts[i] - pts[self], pts[i] - pts[self]));
    EXPECT_EQ(tree.nearestSquared(pts[self], self), best);
  }
  EXPECT_EQ(tree.nearestSquared(pts[10], 10), 0.0f);
}

// Normal estimation of scans without normals: the least-spread direction of points scattered on
// randomly oriented planes (with a little noise) is the plane's normal, up to sign.
TEST(SurfelPointNormals, LeastSpreadDirectionIsThePlaneNormal) {
  std::mt19937 rng(3);
  std::normal_distribution<double> g;
  for (int trial = 0; trial < 200; ++trial) {
    glm::dvec3 n = glm::normalize(glm::dvec3(g(rng), g(rng), g(rng)));
    glm::dvec3 u = glm::normalize(glm::cross(n, std::abs(n.x) < 0.9 ? glm::dvec3(1, 0, 0) : glm::dvec3(0, 1, 0)));
    glm::dvec3 v = glm::cross(n, u);
    double su = 0.5 + trial % 7, sv = 1.0 + trial % 3; // anisotropic in the plane, too
    std::vector<glm::dvec3> pts;
    glm::dvec3 mean(0.0);
    for (int i = 0; i < 16; ++i) {
      pts.push_back(su * g(rng) * u + sv * g(rng) * v + 0.01 * g(rng) * n);
      mean += pts.back();
    }
    mean /= 16.0;
    glm::dmat3 c(0.0);
    for (const glm::dvec3& p : pts) c += glm::outerProduct(p - mean, p - mean);
    glm::vec3 e = leastSpreadDirection(c);
    EXPECT_NEAR(glm::length(e), 1.0f, 1e-5f);
    EXPECT_GT(std::abs(glm::dot(glm::dvec3(e), n)), 0.99) << trial;
  }
  EXPECT_EQ(leastSpreadDirection(glm::dmat3(2.0)), glm::vec3(0, 0, 1)); // isotropic: no direction
  EXPECT_GT(
      std::abs(leastSpreadDirection(glm::dmat3(glm::dvec3(3, 0, 0), glm::dvec3(0, 0.1, 0), glm::dvec3(0, 0, 2))).y),
      0.999f);
}
