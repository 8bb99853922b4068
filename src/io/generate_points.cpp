// Synthetic scans for the point-cloud paths of the surfel sampler (mirage gen points): points
// spread uniformly over a mesh scene's surface, with normals and colours, as a scanner delivers.
#include <algorithm>
#include <random>

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include "mirage/io/generate.h"

namespace mirage::io {

namespace {

// One world-space triangle of the source scene.
struct SourceTriangle {
  const Mesh* mesh;
  const Instance* instance;
  uint32_t first; // index of its first corner in mesh->indices
};

} // namespace

Result<Scene> samplePointCloud(const Scene& source, uint64_t count, uint32_t seed, double* surfaceArea) {
  if (count == 0) return Error{"point count must be at least 1"};
  if (count >= (1ull << 32)) return Error{"point count must be below 2^32"};
  std::vector<SourceTriangle> triangles;
  std::vector<double> cumulativeArea; // running sum, for area-weighted picks by binary search
  double total = 0.0;
  for (const Instance& inst : source.instances) {
    if (inst.mesh >= source.meshes.size()) continue;
    const Mesh& m = source.meshes[inst.mesh];
    for (uint32_t t = 0; t + 2 < m.indices.size(); t += 3) {
      glm::vec3 a = glm::vec3(inst.transform * glm::vec4(m.positions[m.indices[t]], 1.0f));
      glm::vec3 b = glm::vec3(inst.transform * glm::vec4(m.positions[m.indices[t + 1]], 1.0f));
      glm::vec3 c = glm::vec3(inst.transform * glm::vec4(m.positions[m.indices[t + 2]], 1.0f));
      double area = 0.5 * double(glm::length(glm::cross(b - a, c - a)));
      if (!(area > 0.0)) continue;
      total += area;
      triangles.push_back({&m, &inst, t});
      cumulativeArea.push_back(total);
    }
  }
  if (triangles.empty()) return Error{fmt::format("{}: no triangles to sample points on", source.source)};
  if (surfaceArea) *surfaceArea = total;

  Mesh cloud;
  cloud.name = "scan";
  cloud.positions.resize(count);
  cloud.normals.resize(count);
  cloud.colors.resize(count);
  // Blocks of points with their own generator (seeded by seed and block): the same points on any
  // number of threads.
  constexpr uint64_t kBlock = 1 << 16;
  uint64_t blocks = (count + kBlock - 1) / kBlock;
  tbb::parallel_for(uint64_t(0), blocks, [&](uint64_t block) {
    std::mt19937_64 rng(uint64_t(seed) * 0x9E3779B97F4A7C15ull + block);
    std::uniform_real_distribution<double> pick(0.0, total);
    std::uniform_real_distribution<float> unit(0.0f, 1.0f);
    for (uint64_t i = block * kBlock; i < std::min(count, (block + 1) * kBlock); ++i) {
      size_t t =
          size_t(std::upper_bound(cumulativeArea.begin(), cumulativeArea.end(), pick(rng)) - cumulativeArea.begin());
      t = std::min(t, triangles.size() - 1);
      const SourceTriangle& tri = triangles[t];
      const Mesh& m = *tri.mesh;
      float u = unit(rng), v = unit(rng);
      if (u + v > 1.0f) u = 1.0f - u, v = 1.0f - v; // fold the square onto the triangle: uniform
      float w[3] = {1.0f - u - v, u, v};
      glm::vec3 p(0.0f), n(0.0f);
      glm::vec4 color(0.0f);
      for (int k = 0; k < 3; ++k) {
        uint32_t vi = m.indices[tri.first + k];
        p += w[k] * m.positions[vi];
        if (vi < m.normals.size()) n += w[k] * m.normals[vi];
        if (vi < m.colors.size()) color += w[k] * m.colors[vi];
      }
      glm::mat3 normalMatrix = glm::transpose(glm::inverse(glm::mat3(tri.instance->transform)));
      glm::vec3 a = m.positions[m.indices[tri.first]], b = m.positions[m.indices[tri.first + 1]],
                c = m.positions[m.indices[tri.first + 2]];
      if (glm::dot(n, n) == 0.0f) n = glm::cross(b - a, c - a); // no vertex normals: the face's
      n = glm::normalize(normalMatrix * n);
      cloud.positions[i] = glm::vec3(tri.instance->transform * glm::vec4(p, 1.0f));
      cloud.normals[i] = n;
      cloud.colors[i] = m.colors.empty() ? glm::vec4(n * 0.5f + 0.5f, 1.0f) : color;
    }
  });
  for (glm::vec3 p : cloud.positions) cloud.bounds.add(p);
  Scene out;
  out.source = fmt::format("{} points on {}", count, source.source);
  out.meshes.push_back(std::move(cloud));
  out.materials.resize(1);
  out.instances.push_back({0, glm::mat4(1.0f)});
  return out;
}

} // namespace mirage::io
