#include "vis_scenes.h"

#include <gtest/gtest.h>

#include "mirage/io/generate.h"
#include "mirage/visibility/ray_backend.h"

namespace mirage::test {

namespace {

void quad(Mesh& m, glm::vec3 a, glm::vec3 b, glm::vec3 c, glm::vec3 d) {
  uint32_t base = uint32_t(m.positions.size());
  m.positions.insert(m.positions.end(), {a, b, c, d});
  glm::vec3 n = glm::normalize(glm::cross(b - a, d - a));
  m.normals.insert(m.normals.end(), 4, n);
  m.indices.insert(m.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
}

// Axis-aligned rectangle in the plane z (x0..x1, y0..y1), split into nx × ny quads.
void rectZ(Mesh& m, float x0, float x1, float y0, float y1, float z, int nx = 1, int ny = 1) {
  for (int j = 0; j < ny; ++j)
    for (int i = 0; i < nx; ++i) {
      float ax = x0 + (x1 - x0) * float(i) / float(nx), bx = x0 + (x1 - x0) * float(i + 1) / float(nx);
      float ay = y0 + (y1 - y0) * float(j) / float(ny), by = y0 + (y1 - y0) * float(j + 1) / float(ny);
      quad(m, {ax, ay, z}, {bx, ay, z}, {bx, by, z}, {ax, by, z});
    }
}

Mesh named(const std::string& name) {
  Mesh m;
  m.name = name;
  return m;
}

Scene assemble(std::vector<Mesh> meshes) {
  Scene s;
  s.source = "synthetic";
  s.materials.push_back(Material{});
  for (Mesh& m : meshes) {
    for (glm::vec3 p : m.positions) m.bounds.add(p);
    s.instances.push_back({uint32_t(s.meshes.size()), glm::mat4(1.0f)});
    s.meshes.push_back(std::move(m));
  }
  return s;
}

} // namespace

VisScene wallWithHole() {
  Mesh wall = named("wall");
  rectZ(wall, -10, -1, -10, 10, 0);
  rectZ(wall, 1, 10, -10, 10, 0);
  rectZ(wall, -1, 1, -10, -1, 0);
  rectZ(wall, -1, 1, 1, 10, 0);
  Mesh target = named("target");
  rectZ(target, -0.5f, 0.5f, -0.5f, 0.5f, 5);
  Mesh hidden = named("hidden");
  rectZ(hidden, 6, 9, -1, 1, 5);
  Mesh backdrop = named("backdrop");
  rectZ(backdrop, -20, 20, -20, 20, 10, 20, 20);
  VisScene v;
  v.scene = assemble({wall, target, hidden, backdrop});
  v.cell.position = {0, 0, -3};
  v.cell.size = {1, 1, 1};
  return v;
}

VisScene roomWithWindow() {
  Mesh room = named("room");
  const float h = 5;
  // Floor, ceiling, side walls, back wall: plain quads; front wall (+Z) around the window.
  quad(room, {-h, -h, -h}, {h, -h, -h}, {h, -h, h}, {-h, -h, h});
  quad(room, {-h, h, -h}, {h, h, -h}, {h, h, h}, {-h, h, h});
  quad(room, {-h, -h, -h}, {-h, h, -h}, {-h, h, h}, {-h, -h, h});
  quad(room, {h, -h, -h}, {h, h, -h}, {h, h, h}, {h, -h, h});
  rectZ(room, -h, h, -h, h, -h);
  rectZ(room, -h, -1, -h, h, h);
  rectZ(room, 1, h, -h, h, h);
  rectZ(room, -1, 1, -h, -1, h);
  rectZ(room, -1, 1, 1, h, h);
  Mesh tree = named("tree");
  rectZ(tree, -1, 1, -1, 1, 8);
  Mesh shed = named("shed");
  rectZ(shed, 5, 7, -1, 1, 8);
  Mesh back = named("back");
  rectZ(back, -3, 3, -3, 3, -8);
  VisScene v;
  v.scene = assemble({room, tree, shed, back});
  v.cell.position = {0, 0, 0};
  v.cell.size = {2, 2, 2};
  return v;
}

VisScene glassPanes() {
  Mesh front = named("front"), wall = named("wall"), behind = named("behind");
  for (float z : {1.0f, 2.0f, 3.0f}) rectZ(front, -10, 10, -10, 10, z, 4, 4);
  rectZ(wall, -10, 10, -10, 10, 5, 4, 4);
  rectZ(behind, -10, 10, -10, 10, 7, 4, 4);
  front.material = 1;
  behind.material = 1;
  VisScene v;
  v.scene = assemble({std::move(front), std::move(wall), std::move(behind)});
  Material glass;
  glass.alphaMode = AlphaMode::Blend;
  v.scene.materials.push_back(glass);
  v.cell.position = {0.0f, 0.0f, -1.0f};
  v.cell.size = {2.0f, 2.0f, 0.5f};
  return v;
}

std::vector<uint32_t> meshTriangles(const Scene& scene, const std::string& name) {
  auto offsets = vis::triangleOffsets(scene);
  std::vector<uint32_t> out;
  for (size_t i = 0; i < scene.instances.size(); ++i)
    if (scene.meshes[scene.instances[i].mesh].name == name)
      for (uint64_t t = offsets[i]; t < offsets[i + 1]; ++t) out.push_back(uint32_t(t));
  return out;
}

Scene cityScene(uint32_t blocks) {
  auto scene = io::generateScene("city", 4, blocks);
  EXPECT_TRUE(scene.ok());
  return std::move(*scene);
}

vis::ViewCell streetCell() {
  vis::ViewCell cell;
  cell.position = {0.0f, 1.7f, -38.0f};
  cell.size = {4.0f, 2.0f, 4.0f};
  return cell;
}

} // namespace mirage::test
