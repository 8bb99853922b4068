// Emitter shapes: every sample on or in its shape, directions within their bounds, arcs limited,
// volumes filled uniformly, and the shape and emitter transforms applied.
#include <cmath>

#include <gtest/gtest.h>

#include "mirage/particles/simulation.h"

using namespace mirage;
using namespace mirage::particles;
namespace sio = mirage::shaderio;

namespace {

constexpr uint32_t kSamples = 20000;

struct Sample {
  glm::vec3 position;
  glm::vec3 direction;
};

std::vector<Sample> sample(const SystemDef& s) {
  sio::ParticleParams e = flattenSystem(s);
  std::vector<Sample> out(kSamples);
  for (uint32_t i = 0; i < kSamples; ++i) sio::particleShapeSample(e, i, out[i].position, out[i].direction);
  return out;
}

SystemDef withShape(ShapeType type, float radius, float thickness) {
  SystemDef s;
  s.shape.type = type;
  s.shape.radius = radius;
  s.shape.radiusThickness = thickness;
  return s;
}

float degreesAround(glm::vec3 p) { return glm::degrees(std::atan2(p.z, p.x)); }

TEST(ParticleShape, SphereShellAtRadiusAndCentred) {
  glm::vec3 mean(0.0f);
  for (const Sample& x : sample(withShape(ShapeType::Sphere, 2.0f, 0.0f))) {
    ASSERT_NEAR(glm::length(x.position), 2.0f, 1e-5f);
    ASSERT_NEAR(glm::dot(x.direction, glm::normalize(x.position)), 1.0f, 1e-5f); // outward
    mean += x.position / float(kSamples);
  }
  EXPECT_LT(glm::length(mean), 0.05f);
}

TEST(ParticleShape, SphereVolumeUniform) {
  uint32_t inner = 0;
  for (const Sample& x : sample(withShape(ShapeType::Sphere, 1.0f, 1.0f))) {
    ASSERT_LE(glm::length(x.position), 1.0f + 1e-5f);
    inner += glm::length(x.position) < 0.5f;
  }
  EXPECT_NEAR(double(inner) / kSamples, 1.0 / 8.0, 0.01); // the inner half radius holds 1/8 of the volume
}

TEST(ParticleShape, HemisphereUpperHalf) {
  float minY = 1.0f;
  for (const Sample& x : sample(withShape(ShapeType::Hemisphere, 1.0f, 0.0f))) {
    ASSERT_GE(x.position.y, -1e-6f);
    ASSERT_NEAR(glm::length(x.position), 1.0f, 1e-5f);
    minY = std::min(minY, x.position.y);
  }
  EXPECT_LT(minY, 0.01f);
}

TEST(ParticleShape, ConeDirectionsWithinAngleAndBaseOnDisc) {
  SystemDef s = withShape(ShapeType::Cone, 0.5f, 1.0f);
  s.shape.angleDegrees = 30.0f;
  float widest = 0.0f;
  for (const Sample& x : sample(s)) {
    float angle = glm::degrees(std::acos(std::clamp(x.direction.y, -1.0f, 1.0f)));
    ASSERT_LE(angle, 30.0f + 1e-3f);
    widest = std::max(widest, angle);
    ASSERT_NEAR(x.position.y, 0.0f, 1e-6f);
    ASSERT_LE(glm::length(x.position), 0.5f + 1e-5f);
  }
  EXPECT_GT(widest, 29.0f);
}

TEST(ParticleShape, CircleArcLimits) {
  SystemDef s = withShape(ShapeType::Circle, 1.0f, 0.0f);
  s.shape.arcDegrees = 90.0f;
  for (const Sample& x : sample(s)) {
    ASSERT_NEAR(glm::length(x.position), 1.0f, 1e-5f);
    ASSERT_NEAR(x.position.y, 0.0f, 1e-6f);
    float a = degreesAround(x.position);
    ASSERT_GE(a, -1e-3f);
    ASSERT_LE(a, 90.0f + 1e-3f);
  }
  s.shape.type = ShapeType::Sphere;
  for (const Sample& x : sample(s)) {
    float a = degreesAround(x.position);
    ASSERT_GE(a, -1e-3f);
    ASSERT_LE(a, 90.0f + 1e-3f);
  }
}

TEST(ParticleShape, BoxVolumeShellEdge) {
  SystemDef s = withShape(ShapeType::Box, 1.0f, 1.0f);
  s.shape.boxSize = {2.0f, 4.0f, 6.0f};
  glm::vec3 half = s.shape.boxSize * 0.5f;
  for (BoxEmit mode : {BoxEmit::Volume, BoxEmit::Shell, BoxEmit::Edge}) {
    s.shape.boxEmit = mode;
    for (const Sample& x : sample(s)) {
      int onFace = 0;
      for (int a = 0; a < 3; ++a) {
        ASSERT_LE(std::abs(x.position[a]), half[a] + 1e-5f);
        onFace += std::abs(std::abs(x.position[a]) - half[a]) < 1e-5f;
      }
      if (mode == BoxEmit::Shell) {
        ASSERT_GE(onFace, 1);
      }
      if (mode == BoxEmit::Edge) {
        ASSERT_GE(onFace, 2);
      }
      ASSERT_EQ(x.direction, glm::vec3(0, 1, 0));
    }
  }
}

TEST(ParticleShape, EdgeSegment) {
  for (const Sample& x : sample(withShape(ShapeType::Edge, 3.0f, 1.0f))) {
    ASSERT_LE(std::abs(x.position.x), 3.0f);
    ASSERT_EQ(x.position.y, 0.0f);
    ASSERT_EQ(x.position.z, 0.0f);
  }
}

TEST(ParticleShape, TransformsAndRandomization) {
  SystemDef s = withShape(ShapeType::Sphere, 1.0f, 0.0f);
  s.position = {10.0f, 0.0f, 0.0f};
  s.shape.position = {0.0f, 5.0f, 0.0f};
  s.shape.scale = {2.0f, 1.0f, 1.0f};
  glm::vec3 mean(0.0f), extent(0.0f);
  for (const Sample& x : sample(s)) {
    mean += x.position / float(kSamples);
    extent = glm::max(extent, glm::abs(x.position - glm::vec3(10, 5, 0)));
  }
  EXPECT_LT(glm::length(mean - glm::vec3(10, 5, 0)), 0.05f);
  EXPECT_NEAR(extent.x, 2.0f, 0.02f);
  EXPECT_NEAR(extent.y, 1.0f, 0.02f);
  // The emitter's rotation turns the cone: 180 degrees about X sends particles down.
  SystemDef cone = withShape(ShapeType::Cone, 0.1f, 1.0f);
  cone.shape.angleDegrees = 10.0f;
  cone.rotationDegrees = {180.0f, 0.0f, 0.0f};
  for (const Sample& x : sample(cone)) ASSERT_LT(x.direction.y, -0.98f);
  // Randomized direction 1: directions cover the sphere (mean near zero).
  SystemDef r = withShape(ShapeType::Edge, 0.0f, 1.0f);
  r.shape.randomizeDirection = 1.0f;
  r.shape.randomizePosition = 0.5f;
  glm::vec3 d(0.0f);
  for (const Sample& x : sample(r)) {
    d += x.direction / float(kSamples);
    ASSERT_NEAR(glm::length(x.direction), 1.0f, 1e-5f);
    ASSERT_LE(glm::max(glm::abs(x.position).x, glm::max(glm::abs(x.position).y, glm::abs(x.position).z)), 0.5f + 1e-5f);
  }
  EXPECT_LT(glm::length(d), 0.05f);
}

} // namespace
