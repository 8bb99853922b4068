#include "mirage/core/scene.h"

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

} // namespace mirage
