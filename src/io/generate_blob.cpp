// Blob: an icosphere displaced along its normals by 3D fBm. Built as 20 triangular face grids of
// n segments per edge (2^s, or any n) that share their edge and corner vertices, which gives exactly the
// subdivided-icosahedron topology (closed, 2-manifold, 10n²+2 vertices, 20n² triangles) without a
// hash map of edge midpoints, so s = 10 (21M triangles) stays fast and lean.
#include <algorithm>
#include <array>
#include <map>

#include <tbb/parallel_for.h>

#include "generate_common.h"
#include "mirage/io/generate.h"

namespace mirage::io {

namespace {

constexpr float kPhi = 1.6180339887498949f;
const std::array<glm::vec3, 12> kIcoVertices = {{{-1, kPhi, 0},
                                                 {1, kPhi, 0},
                                                 {-1, -kPhi, 0},
                                                 {1, -kPhi, 0},
                                                 {0, -1, kPhi},
                                                 {0, 1, kPhi},
                                                 {0, -1, -kPhi},
                                                 {0, 1, -kPhi},
                                                 {kPhi, 0, -1},
                                                 {kPhi, 0, 1},
                                                 {-kPhi, 0, -1},
                                                 {-kPhi, 0, 1}}};
// Counter-clockwise seen from outside.
const std::array<std::array<uint32_t, 3>, 20> kIcoFaces = {
    {{0, 11, 5},  {0, 5, 1},  {0, 1, 7},  {0, 7, 10}, {0, 10, 11}, {1, 5, 9}, {5, 11, 4},
     {11, 10, 2}, {10, 7, 6}, {7, 1, 8},  {3, 9, 4},  {3, 4, 2},   {3, 2, 6}, {3, 6, 8},
     {3, 8, 9},   {4, 9, 5},  {2, 4, 11}, {6, 2, 10}, {8, 6, 7},   {9, 8, 1}}};

} // namespace

Scene generateBlob(const BlobOptions& options) {
  // Segments per icosahedron edge: 2^subdivisions, or any count (a triangle budget between powers).
  const uint32_t n = options.segments ? std::clamp<uint32_t>(options.segments, 1, 8192)
                                      : 1u << std::min<uint32_t>(options.subdivisions, 11);
  const size_t edgeVerts = n - 1, faceVerts = size_t(n - 1) * (n - 2) / 2;
  const size_t vertexCount = 12 + 30 * edgeVerts + 20 * faceVerts;

  // The 30 icosahedron edges, numbered in face order so the layout is fixed.
  std::map<std::pair<uint32_t, uint32_t>, uint32_t> edgeIds;
  std::array<std::pair<uint32_t, uint32_t>, 30> edges{};
  for (const auto& f : kIcoFaces)
    for (int k = 0; k < 3; ++k) {
      auto key = std::minmax(f[k], f[(k + 1) % 3]);
      if (edgeIds.emplace(key, uint32_t(edgeIds.size())).second) edges[edgeIds.size() - 1] = key;
    }
  std::array<std::array<uint32_t, 3>, 20> faceEdges{}; // edges a-b, a-c, b-c of each face
  for (size_t f = 0; f < 20; ++f) {
    auto [a, b, c] = kIcoFaces[f];
    faceEdges[f] = {edgeIds[std::minmax(a, b)], edgeIds[std::minmax(a, c)], edgeIds[std::minmax(b, c)]};
  }

  // Global index of grid point (i, j) of face f: the point (n-i-j)/n·a + i/n·b + j/n·c.
  auto vertexIndex = [&](uint32_t f, uint32_t i, uint32_t j) -> uint32_t {
    auto [a, b, c] = kIcoFaces[f];
    auto onEdge = [&](uint32_t e, uint32_t from, uint32_t k) { // k steps from vertex `from`
      uint32_t step = from == edges[e].first ? k : n - k;
      return uint32_t(12 + size_t(e) * edgeVerts + (step - 1));
    };
    if (i == 0 && j == 0) return a;
    if (i == n) return b;
    if (j == n) return c;
    if (j == 0) return onEdge(faceEdges[f][0], a, i);
    if (i == 0) return onEdge(faceEdges[f][1], a, j);
    if (i + j == n) return onEdge(faceEdges[f][2], b, j);
    size_t row = size_t(j - 1) * (n - 1) - size_t(j - 1) * j / 2; // interior rows j = 1..n-2
    return uint32_t(12 + 30 * edgeVerts + f * faceVerts + row + (i - 1));
  };

  Mesh mesh;
  mesh.name = "blob";
  std::vector<glm::vec3>& pos = mesh.positions;
  pos.resize(vertexCount);
  // Directions on the unit sphere. Each vertex is computed once by its owner (corner, edge or face)
  // from canonical endpoints, so shared vertices are bit-identical wherever they are referenced.
  for (uint32_t v = 0; v < 12; ++v) pos[v] = glm::normalize(kIcoVertices[v]);
  tbb::parallel_for(uint32_t(0), uint32_t(30), [&](uint32_t e) {
    glm::vec3 p0 = kIcoVertices[edges[e].first], p1 = kIcoVertices[edges[e].second];
    for (uint32_t k = 1; k < n; ++k)
      pos[12 + size_t(e) * edgeVerts + (k - 1)] = glm::normalize(glm::mix(p0, p1, float(k) / float(n)));
  });
  tbb::parallel_for(uint32_t(0), uint32_t(20), [&](uint32_t f) {
    auto [a, b, c] = kIcoFaces[f];
    for (uint32_t j = 1; j + 1 < n; ++j)
      for (uint32_t i = 1; i + j < n; ++i) {
        glm::vec3 p = kIcoVertices[a] * (float(n - i - j) / float(n)) + kIcoVertices[b] * (float(i) / float(n)) +
                      kIcoVertices[c] * (float(j) / float(n));
        pos[vertexIndex(f, i, j)] = glm::normalize(p);
      }
  });
  // Displace along the sphere normal: radius · (1 + amplitude · fBm(direction · frequency)).
  tbb::parallel_for(tbb::blocked_range<size_t>(0, vertexCount, 4096), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v) {
      float d = detail::fbm3(pos[v] * options.frequency, options.octaves, options.seed);
      pos[v] *= options.radius * (1.0f + options.amplitude * d);
    }
  });

  mesh.indices.resize(size_t(20) * n * n * 3);
  tbb::parallel_for(uint32_t(0), uint32_t(20), [&](uint32_t f) {
    uint32_t* out = &mesh.indices[size_t(f) * n * n * 3];
    for (uint32_t j = 0; j < n; ++j)
      for (uint32_t i = 0; i + j < n; ++i) {
        uint32_t p = vertexIndex(f, i, j), q = vertexIndex(f, i + 1, j), r = vertexIndex(f, i, j + 1);
        *out++ = p, *out++ = q, *out++ = r; // same orientation as the face (a -> b -> c)
        if (i + j + 1 < n) {
          uint32_t t = vertexIndex(f, i + 1, j + 1);
          *out++ = q, *out++ = t, *out++ = r;
        }
      }
  });

  // Area-weighted vertex normals. Accumulated serially in index order: a parallel scatter would
  // need atomics and make the float sums (and so the bytes) depend on scheduling.
  mesh.normals.assign(vertexCount, glm::vec3(0.0f));
  for (size_t t = 0; t < mesh.indices.size(); t += 3) {
    uint32_t i0 = mesh.indices[t], i1 = mesh.indices[t + 1], i2 = mesh.indices[t + 2];
    glm::vec3 nrm = glm::cross(pos[i1] - pos[i0], pos[i2] - pos[i0]);
    mesh.normals[i0] += nrm;
    mesh.normals[i1] += nrm;
    mesh.normals[i2] += nrm;
  }
  tbb::parallel_for(tbb::blocked_range<size_t>(0, vertexCount, 8192), [&](const tbb::blocked_range<size_t>& r) {
    for (size_t v = r.begin(); v != r.end(); ++v) {
      float len = glm::length(mesh.normals[v]);
      mesh.normals[v] = len > 0.0f ? mesh.normals[v] / len : glm::normalize(pos[v]);
    }
  });
  detail::computeBounds(mesh);

  Scene scene;
  scene.source = "generated:blob";
  Material clay;
  clay.name = "blob";
  clay.baseColorFactor = glm::vec4(0.7f, 0.45f, 0.35f, 1.0f);
  clay.metallicFactor = 0.0f;
  clay.roughnessFactor = 0.55f;
  scene.materials.push_back(clay);
  scene.meshes.push_back(std::move(mesh));
  scene.instances.push_back({0, glm::mat4(1.0f)});
  return scene;
}

} // namespace mirage::io
