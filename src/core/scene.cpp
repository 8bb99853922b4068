#include "mirage/core/scene.h"

#include <algorithm>
#include <cmath>

namespace mirage {

size_t Scene::instancedTriangleCount() const {
  size_t n = 0;
  for (const Instance& i : instances) n += meshes[i.mesh].triangleCount();
  return n;
}

size_t Scene::meshTriangleCount() const {
  size_t n = 0;
  for (const Mesh& m : meshes) n += m.triangleCount();
  return n;
}

Bounds transformBounds(const Bounds& b, const glm::mat4& m) {
  Bounds out;
  if (b.empty()) return out;
  for (int c = 0; c < 8; ++c) {
    glm::vec3 p{(c & 1) ? b.max.x : b.min.x, (c & 2) ? b.max.y : b.min.y, (c & 4) ? b.max.z : b.min.z};
    out.add(glm::vec3(m * glm::vec4(p, 1.0f)));
  }
  return out;
}

Bounds Scene::worldBounds() const {
  Bounds out;
  for (const Instance& i : instances) out.add(transformBounds(meshes[i.mesh].bounds, i.transform));
  return out;
}

float maxAxisScale(const glm::mat4& m) {
  return std::max({glm::length(glm::vec3(m[0])), glm::length(glm::vec3(m[1])), glm::length(glm::vec3(m[2]))});
}

void repeatOnGrid(Scene& scene, uint32_t copies) {
  if (copies <= 1) return;
  Bounds b = scene.worldBounds();
  float spacing = 1.25f * std::max(b.extent().x, b.extent().z);
  if (!(spacing > 0.0f)) spacing = 1.0f; // flat or empty scenes still get distinct positions
  uint32_t perRow = uint32_t(std::ceil(std::sqrt(double(copies))));
  uint32_t rows = (copies + perRow - 1) / perRow;
  std::vector<Instance> grid;
  grid.reserve(size_t(copies) * scene.instances.size());
  for (uint32_t i = 0; i < copies; ++i) {
    uint32_t gx = i % perRow, gz = i / perRow;
    glm::vec3 offset{(float(gx) - 0.5f * float(perRow - 1)) * spacing, 0.0f,
                     (float(gz) - 0.5f * float(rows - 1)) * spacing};
    for (Instance inst : scene.instances) {
      inst.transform[3] += glm::vec4(offset, 0.0f);
      grid.push_back(inst);
    }
  }
  scene.instances = std::move(grid);
}

} // namespace mirage
