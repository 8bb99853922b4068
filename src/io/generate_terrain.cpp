// Terrain: an N×N heightfield of fBm gradient noise; one open mesh, one instance.
#include <algorithm>
#include <cmath>

#include <tbb/parallel_for.h>

#include "generate_common.h"
#include "mirage/io/generate.h"

namespace mirage::io {

Scene generateTerrain(const TerrainOptions& options) {
  const uint32_t n = std::clamp<uint32_t>(options.resolution, 2, 8192);
  const float size = options.size > 0.0f ? options.size : 1.0f;
  const float spacing = size / float(n - 1);
  const float feature = options.featureSize > 0.0f ? options.featureSize : size;
  const size_t count = size_t(n) * n;

  Mesh mesh;
  mesh.name = "terrain";
  mesh.positions.resize(count);
  mesh.normals.resize(count);
  mesh.uv0.resize(count);
  if (options.vertexColors) mesh.colors.resize(count);
  mesh.indices.resize(size_t(n - 1) * (n - 1) * 6);

  // Rows are independent, so they run in parallel; every value depends only on (i, j), which keeps
  // the output identical for any thread count.
  tbb::parallel_for(uint32_t(0), n, [&](uint32_t j) {
    for (uint32_t i = 0; i < n; ++i) {
      float x = -0.5f * size + float(i) * spacing, z = -0.5f * size + float(j) * spacing;
      glm::vec3 q(x / feature, z / feature, 0.5f);
      float f = detail::fbm3(q, options.octaves, options.seed);
      // Squaring the positive part sharpens peaks and leaves valleys broad, which reads as terrain.
      float h = options.heightScale * (f + 0.8f * std::max(f, 0.0f) * std::max(f, 0.0f));
      size_t v = size_t(j) * n + i;
      mesh.positions[v] = {x, h, z};
      mesh.uv0[v] = {float(i) / float(n - 1), float(j) / float(n - 1)};
    }
  });
  tbb::parallel_for(uint32_t(0), n, [&](uint32_t j) {
    for (uint32_t i = 0; i < n; ++i) {
      auto height = [&](uint32_t ii, uint32_t jj) { return mesh.positions[size_t(jj) * n + ii].y; };
      uint32_t i0 = i > 0 ? i - 1 : i, i1 = i + 1 < n ? i + 1 : i;
      uint32_t j0 = j > 0 ? j - 1 : j, j1 = j + 1 < n ? j + 1 : j;
      float dx = (height(i1, j) - height(i0, j)) / (float(i1 - i0) * spacing);
      float dz = (height(i, j1) - height(i, j0)) / (float(j1 - j0) * spacing);
      glm::vec3 normal = glm::normalize(glm::vec3(-dx, 1.0f, -dz));
      size_t v = size_t(j) * n + i;
      mesh.normals[v] = normal;
      if (options.vertexColors) {
        float h = mesh.positions[v].y / std::max(options.heightScale, 1e-6f);
        glm::vec3 grass(0.09f, 0.22f, 0.05f), rock(0.25f, 0.23f, 0.21f), snow(0.85f, 0.87f, 0.9f);
        glm::vec3 c = glm::mix(grass, rock, glm::smoothstep(0.75f, 0.55f, normal.y));
        c = glm::mix(c, snow, glm::smoothstep(0.55f, 0.75f, h) * glm::smoothstep(0.5f, 0.7f, normal.y));
        mesh.colors[v] = glm::vec4(c, 1.0f);
      }
    }
    if (j + 1 == n) return;
    uint32_t* out = &mesh.indices[size_t(j) * (n - 1) * 6];
    for (uint32_t i = 0; i + 1 < n; ++i) {
      uint32_t a = j * n + i, b = a + 1, c = a + n, d = c + 1;
      // Counter-clockwise seen from +Y (x right, z towards the viewer), so faces point up.
      uint32_t tri[6] = {a, c, b, b, c, d};
      std::copy(tri, tri + 6, out + size_t(i) * 6);
    }
  });
  detail::computeBounds(mesh);

  Scene scene;
  scene.source = "generated:terrain";
  Material ground;
  ground.name = "terrain";
  ground.baseColorFactor = glm::vec4(1.0f); // vertex colours carry the albedo
  ground.metallicFactor = 0.0f;
  ground.roughnessFactor = 0.9f;
  if (!options.vertexColors) ground.baseColorFactor = glm::vec4(0.2f, 0.3f, 0.12f, 1.0f);
  scene.materials.push_back(ground);
  scene.meshes.push_back(std::move(mesh));
  scene.instances.push_back({0, glm::mat4(1.0f)});
  return scene;
}

} // namespace mirage::io
