#include "test_scenes.h"

#include <cmath>

namespace mirage::test {

namespace {
void finish(Mesh& m) {
  m.bounds = Bounds{};
  for (const glm::vec3& p : m.positions) m.bounds.add(p);
}
} // namespace

Mesh makeCube(float h, uint32_t material) {
  Mesh m;
  m.name = "cube";
  m.material = material;
  const glm::vec3 normals[6] = {{1, 0, 0}, {-1, 0, 0}, {0, 1, 0}, {0, -1, 0}, {0, 0, 1}, {0, 0, -1}};
  for (const glm::vec3& n : normals) {
    // Two tangent axes u, v with u x v = n, so corners listed (-,-), (+,-), (+,+), (-,+) are CCW from outside.
    glm::vec3 u = std::abs(n.y) > 0.5f ? glm::vec3(1, 0, 0) : glm::vec3(0, 1, 0);
    glm::vec3 v = glm::cross(n, u);
    u = glm::cross(v, n);
    uint32_t base = uint32_t(m.positions.size());
    const float su[4] = {-1, 1, 1, -1}, sv[4] = {-1, -1, 1, 1};
    for (int c = 0; c < 4; ++c) {
      m.positions.push_back((n + su[c] * u + sv[c] * v) * h);
      m.normals.push_back(n);
      m.uv0.push_back({su[c] * 0.5f + 0.5f, sv[c] * 0.5f + 0.5f});
    }
    m.indices.insert(m.indices.end(), {base, base + 1, base + 2, base, base + 2, base + 3});
  }
  finish(m);
  return m;
}

Mesh makeQuad(float h, float z, uint32_t material) {
  Mesh m;
  m.name = "quad";
  m.material = material;
  m.positions = {{-h, -h, z}, {h, -h, z}, {h, h, z}, {-h, h, z}};
  m.normals.assign(4, {0, 0, 1});
  m.uv0 = {{0, 1}, {1, 1}, {1, 0}, {0, 0}};
  m.indices = {0, 1, 2, 0, 2, 3};
  finish(m);
  return m;
}

Mesh makeGrid(float h, float z, uint32_t material, int n) {
  Mesh m;
  m.name = "grid";
  m.material = material;
  for (int y = 0; y <= n; ++y)
    for (int x = 0; x <= n; ++x) {
      float u = float(x) / float(n), v = float(y) / float(n);
      m.positions.push_back({(u * 2.0f - 1.0f) * h, (v * 2.0f - 1.0f) * h, z});
      m.normals.push_back({0, 0, 1});
      m.uv0.push_back({u, 1.0f - v});
    }
  for (int y = 0; y < n; ++y)
    for (int x = 0; x < n; ++x) {
      uint32_t a = uint32_t(y * (n + 1) + x), b = a + 1, c = a + uint32_t(n) + 2, d = a + uint32_t(n) + 1;
      m.indices.insert(m.indices.end(), {a, b, c, a, c, d});
    }
  finish(m);
  return m;
}

Mesh makeSphere(float radius, uint32_t rings, uint32_t segments, uint32_t material) {
  Mesh m;
  m.name = "sphere";
  m.material = material;
  const float pi = 3.14159265358979f;
  for (uint32_t r = 0; r <= rings; ++r) {
    float theta = pi * float(r) / float(rings);
    for (uint32_t s = 0; s <= segments; ++s) {
      float phi = 2.0f * pi * float(s) / float(segments);
      glm::vec3 n{std::sin(theta) * std::cos(phi), std::cos(theta), -std::sin(theta) * std::sin(phi)};
      m.positions.push_back(n * radius);
      m.normals.push_back(n);
      m.uv0.push_back({float(s) / float(segments), float(r) / float(rings)});
    }
  }
  for (uint32_t r = 0; r < rings; ++r)
    for (uint32_t s = 0; s < segments; ++s) {
      uint32_t a = r * (segments + 1) + s, b = a + segments + 1;
      m.indices.insert(m.indices.end(), {a, b, a + 1, a + 1, b, b + 1});
    }
  finish(m);
  return m;
}

Scene makeScene(std::vector<Mesh> meshes, std::vector<Material> materials) {
  Scene s;
  s.source = "test";
  s.meshes = std::move(meshes);
  s.materials = std::move(materials);
  if (s.materials.empty()) s.materials.push_back(Material{});
  for (uint32_t i = 0; i < s.meshes.size(); ++i) s.instances.push_back({i, glm::mat4(1.0f)});
  return s;
}

Material solidMaterial(glm::vec4 color, AlphaMode mode, bool doubleSided) {
  Material m;
  m.baseColorFactor = color;
  m.metallicFactor = 0.0f;
  m.roughnessFactor = 0.8f;
  m.alphaMode = mode;
  m.doubleSided = doubleSided;
  return m;
}

Texture checkerCutout() {
  Texture checker;
  checker.name = "checker";
  checker.width = checker.height = 8;
  for (uint32_t y = 0; y < 8; ++y)
    for (uint32_t x = 0; x < 8; ++x)
      checker.rgba8.insert(checker.rgba8.end(), {255, 255, 255, uint8_t((x + y) % 2 ? 0 : 255)});
  return checker;
}

} // namespace mirage::test
