#include <gtest/gtest.h>

#include <glm/gtc/matrix_transform.hpp>

#include "mirage/core/scene.h"

using namespace mirage;

TEST(Bounds, TransformCoversRotatedBox) {
  Bounds b;
  b.add({-1, -1, -1});
  b.add({1, 1, 1});
  glm::mat4 m = glm::rotate(glm::mat4(1.0f), glm::radians(45.0f), glm::vec3(0, 1, 0));
  Bounds t = transformBounds(b, m);
  EXPECT_NEAR(t.max.x, std::sqrt(2.0f), 1e-5f);
  EXPECT_NEAR(t.min.z, -std::sqrt(2.0f), 1e-5f);
  EXPECT_NEAR(t.max.y, 1.0f, 1e-6f);
}

TEST(Scene, CountsInstancedTriangles) {
  Scene s;
  Mesh m;
  m.positions = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}};
  m.indices = {0, 1, 2};
  m.bounds.add({0, 0, 0});
  m.bounds.add({1, 1, 0});
  s.meshes.push_back(m);
  s.instances.push_back({0, glm::mat4(1.0f)});
  s.instances.push_back({0, glm::translate(glm::mat4(1.0f), glm::vec3(5, 0, 0))});
  EXPECT_EQ(s.meshTriangleCount(), 1u);
  EXPECT_EQ(s.instancedTriangleCount(), 2u);
  EXPECT_FLOAT_EQ(s.worldBounds().max.x, 6.0f);
}
