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

// Grid copies: the requested count, meshes shared, copies disjoint and centred on the original.
TEST(Scene, RepeatOnGridPlacesDisjointCopies) {
  Scene s;
  Mesh m;
  m.positions = {{0, 0, 0}, {2, 0, 0}, {0, 1, 3}};
  m.indices = {0, 1, 2};
  for (auto& p : m.positions) m.bounds.add(p);
  s.meshes.push_back(m);
  s.instances.push_back({0, glm::mat4(1.0f)});
  s.instances.push_back({0, glm::translate(glm::mat4(1.0f), glm::vec3(1, 0, 0))});
  Bounds original = s.worldBounds();
  repeatOnGrid(s, 7);
  ASSERT_EQ(s.instances.size(), 14u);
  EXPECT_EQ(s.meshes.size(), 1u);
  std::vector<Bounds> copies;
  for (size_t c = 0; c < 7; ++c) {
    Bounds b;
    for (size_t i = 0; i < 2; ++i) b.add(transformBounds(m.bounds, s.instances[c * 2 + i].transform));
    EXPECT_NEAR(b.extent().x, original.extent().x, 1e-5f);
    copies.push_back(b);
  }
  for (size_t a = 0; a < copies.size(); ++a)
    for (size_t b = a + 1; b < copies.size(); ++b) {
      bool overlapX = copies[a].min.x < copies[b].max.x && copies[b].min.x < copies[a].max.x;
      bool overlapZ = copies[a].min.z < copies[b].max.z && copies[b].min.z < copies[a].max.z;
      EXPECT_FALSE(overlapX && overlapZ) << "copies " << a << " and " << b << " overlap";
    }
  glm::vec3 centre = 0.5f * (s.worldBounds().min + s.worldBounds().max);
  glm::vec3 originalCentre = 0.5f * (original.min + original.max);
  EXPECT_NEAR(centre.y, originalCentre.y, 1e-5f);
  repeatOnGrid(s, 1); // one copy: unchanged
  EXPECT_EQ(s.instances.size(), 14u);
}
