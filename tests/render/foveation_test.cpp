// Foveation's tau factor (shaderio/lod_error.h, shared with cluster_select.glsl): 1 inside the
// fovea, linear in eccentricity outside it with the acuity model's slope, and never larger for a
// sphere than for one inside it (the monotonicity a crack-free cut needs).
#include <cmath>
#include <random>

#include <glm/gtc/constants.hpp>
#include <gtest/gtest.h>

#include "mirage/shaderio/lod_error.h"

namespace mirage::shaderio {
namespace {

constexpr float kDegree = glm::pi<float>() / 180.0f;
const glm::vec3 kEye{0.0f}, kGaze{0.0f, 0.0f, -1.0f};

// A point sphere at `degrees` from the gaze, 10 units away.
glm::vec3 sphereAt(float degrees) {
  return 10.0f * glm::vec3(std::sin(degrees * kDegree), 0.0f, -std::cos(degrees * kDegree));
}

TEST(Foveation, OneInsideTheFoveaLinearOutside) {
  float r = 5.0f * kDegree, slope = foveaSlope(r);
  EXPECT_FLOAT_EQ(fovealTauScale(sphereAt(0.0f), 0.0f, kEye, kGaze, r, slope), 1.0f);
  EXPECT_FLOAT_EQ(fovealTauScale(sphereAt(4.9f), 0.0f, kEye, kGaze, r, slope), 1.0f);
  // Linear in degrees beyond the fovea: MAR(e) / MAR(r) of MAR = 1/48 deg + 0.022 e.
  for (float e : {10.0f, 20.0f, 40.0f}) {
    float mar = (1.0f / 48.0f + 0.022f * e) / (1.0f / 48.0f + 0.022f * 5.0f);
    EXPECT_NEAR(fovealTauScale(sphereAt(e), 0.0f, kEye, kGaze, r, slope), mar, 1e-3f * mar) << e;
  }
  // The sphere's nearest point counts: a sphere reaching into the fovea is foveal.
  float d = 10.0f, reach = d * std::sin(12.0f * kDegree);
  EXPECT_FLOAT_EQ(fovealTauScale(sphereAt(15.0f), reach, kEye, kGaze, r, slope), 1.0f);
  // The eye inside the sphere: foveal.
  EXPECT_FLOAT_EQ(fovealTauScale(sphereAt(60.0f), 11.0f, kEye, kGaze, r, slope), 1.0f);
  // Behind the viewer: the largest factor, finite.
  float behind = fovealTauScale(sphereAt(180.0f), 0.0f, kEye, kGaze, r, slope);
  EXPECT_TRUE(std::isfinite(behind));
  EXPECT_GT(behind, fovealTauScale(sphereAt(90.0f), 0.0f, kEye, kGaze, r, slope));
}

TEST(Foveation, AContainingSphereNeverGetsALargerFactor) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  float r = 3.0f * kDegree, slope = foveaSlope(r);
  glm::vec3 gaze = glm::normalize(glm::vec3(0.3f, -0.2f, -1.0f));
  for (int i = 0; i < 20000; ++i) {
    glm::vec3 child{u(rng) * 20.0f, u(rng) * 20.0f, u(rng) * 20.0f};
    float childRadius = (u(rng) + 1.0f) * 2.0f;
    // A parent holding the child: centre moved by at most its extra radius.
    float extra = (u(rng) + 1.0f) * 3.0f;
    glm::vec3 offset = glm::vec3(u(rng), u(rng), u(rng)) * (extra / std::sqrt(3.0f));
    float child_ = fovealTauScale(child, childRadius, kEye, gaze, r, slope);
    float parent = fovealTauScale(child + offset, childRadius + extra, kEye, gaze, r, slope);
    ASSERT_LE(parent, child_ * (1.0f + 1e-5f) + 1e-5f) << i;
  }
}

TEST(Foveation, SlopeFollowsTheFoveaRadius) {
  // A wider fovea sits where acuity is already lower: the factor grows more slowly past it.
  EXPECT_GT(foveaSlope(2.0f * kDegree), foveaSlope(10.0f * kDegree));
  EXPECT_NEAR(foveaSlope(0.0f) * kDegree, 0.022f * 48.0f, 1e-3f); // m / w0 per degree
}

} // namespace

} // namespace mirage::shaderio
