#include "mirage/surfels/point_cloud.h"

#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include "kdtree.h"

namespace mirage::surfels {

namespace {

uint32_t packColor(glm::vec4 c) {
  glm::vec4 v = glm::clamp(c, 0.0f, 1.0f) * 255.0f + 0.5f;
  return uint32_t(v.r) | uint32_t(v.g) << 8 | uint32_t(v.b) << 16 | uint32_t(v.a) << 24;
}

bool finite(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

// Point i of mesh m, at world position p: every attribute a sampler reads must be finite.
Status checkFinitePoint(const Mesh& m, size_t i, glm::vec3 p) {
  if (!finite(m.positions[i]))
    return Error{fmt::format("point {} has a non-finite position ({}, {}, {})", i, m.positions[i].x, m.positions[i].y,
                             m.positions[i].z)};
  if (!finite(p)) return Error{fmt::format("point {} is not finite once transformed into the scene", i)};
  if (i < m.normals.size() && !finite(m.normals[i])) return Error{fmt::format("point {} has a non-finite normal", i)};
  if (i < m.colors.size() && (!finite(glm::vec3(m.colors[i])) || !std::isfinite(m.colors[i].a)))
    return Error{fmt::format("point {} has a non-finite colour", i)};
  return Ok{};
}

} // namespace

// What a file holds is decided once, by the importer (PLY faces and triangle strips are triangles; a file without any
// is points only with ImportOptions::allowPointClouds): this only reads the imported scene.
bool isPointCloud(const Scene& scene) {
  if (scene.instancedTriangleCount() > 0) return false;
  for (const Instance& inst : scene.instances)
    if (inst.mesh < scene.meshes.size() && !scene.meshes[inst.mesh].positions.empty()) return true;
  return false;
}

glm::vec3 leastSpreadDirection(const glm::dmat3& a) {
  // Eigenvalues of a symmetric matrix in closed form (Smith 1961): A = qI + pB, eig(B) = 2cos(φ + 2πk/3).
  double offDiagonal = a[0][1] * a[0][1] + a[0][2] * a[0][2] + a[1][2] * a[1][2];
  double q = (a[0][0] + a[1][1] + a[2][2]) / 3.0;
  double p2 =
      (a[0][0] - q) * (a[0][0] - q) + (a[1][1] - q) * (a[1][1] - q) + (a[2][2] - q) * (a[2][2] - q) + 2.0 * offDiagonal;
  double p = std::sqrt(p2 / 6.0);
  if (!(p > 0.0)) return glm::vec3(0, 0, 1);
  glm::dmat3 b = (a - glm::dmat3(q)) / p;
  double phi = std::acos(std::clamp(glm::determinant(b) / 2.0, -1.0, 1.0)) / 3.0;
  double smallest = q + 2.0 * p * std::cos(phi + 2.0 * 3.14159265358979323846 / 3.0);
  // The eigenvector is orthogonal to the rows of A - λI: the longest cross product of two rows.
  glm::dmat3 m = a - glm::dmat3(smallest);
  glm::dvec3 rows[3] = {glm::dvec3(m[0][0], m[1][0], m[2][0]), glm::dvec3(m[0][1], m[1][1], m[2][1]),
                        glm::dvec3(m[0][2], m[1][2], m[2][2])};
  glm::dvec3 best(0.0);
  for (int i = 0; i < 3; ++i) {
    glm::dvec3 c = glm::cross(rows[i], rows[(i + 1) % 3]);
    if (glm::dot(c, c) > glm::dot(best, best)) best = c;
  }
  double len = glm::length(best);
  return len > 0.0 ? glm::vec3(best / len) : glm::vec3(0, 0, 1);
}

Result<ScanPoints> scanPoints(const Scene& scene) {
  std::string source = scene.source.empty() ? "scene" : scene.source;
  ScanPoints s;
  s.hasNormals = true;
  for (const Instance& inst : scene.instances) {
    if (inst.mesh >= scene.meshes.size()) continue;
    const Mesh& m = scene.meshes[inst.mesh];
    glm::mat3 normalMatrix = glm::transpose(glm::inverse(glm::mat3(inst.transform)));
    s.hasNormals = s.hasNormals && m.normals.size() >= m.positions.size();
    for (size_t i = 0; i < m.positions.size(); ++i) {
      glm::vec3 p = glm::vec3(inst.transform * glm::vec4(m.positions[i], 1.0f));
      // One NaN or infinity poisons the spacing, the bounds and every distance the samplers compare
      // (the GPU sampler then never converges): reject it, naming the point as the file numbers it.
      if (Status ok = checkFinitePoint(m, i, p); !ok) return makeError(source, ok.error().message);
      s.positions.push_back(p);
      glm::vec3 n = i < m.normals.size() ? normalMatrix * m.normals[i] : glm::vec3(0, 0, 1);
      float len = glm::length(n);
      s.normals.push_back(len > 0.0f ? n / len : glm::vec3(0, 0, 1));
      s.colors.push_back(i < m.colors.size() ? packColor(m.colors[i]) : 0xffffffffu);
    }
  }
  if (s.size() <= kPointNeighbours)
    return makeError(source,
                     fmt::format("point cloud has {} points; sampling needs more than {}", s.size(), kPointNeighbours));
  if (s.size() >= (1ull << 32)) return makeError(source, "point cloud has 2^32 points or more");
  KdTree tree(s.positions);
  s.spacing.resize(s.size());
  std::span<const uint32_t> order = tree.treeOrder(); // queries in leaf order: warm caches
  tbb::parallel_for(tbb::blocked_range<size_t>(0, s.size(), 4096), [&](const tbb::blocked_range<size_t>& range) {
    for (size_t j = range.begin(); j < range.end(); ++j) {
      uint32_t i = order[j];
      s.spacing[i] = std::sqrt(tree.kthNearestSquared(s.positions[i], kPointNeighbours, i));
      if (s.hasNormals) continue;
      // No normal in the file: the covariance of the point and its k nearest neighbours.
      glm::dvec3 mean(0.0);
      uint32_t count = 0;
      float radius = std::nextafter(s.spacing[i], INFINITY); // the k-th neighbour included
      tree.forEachWithin(s.positions[i], radius,
                         [&](uint32_t k, float) { mean += glm::dvec3(s.positions[k]), ++count; });
      mean /= double(std::max(count, 1u));
      glm::dmat3 covariance(0.0);
      tree.forEachWithin(s.positions[i], radius, [&](uint32_t k, float) {
        glm::dvec3 d = glm::dvec3(s.positions[k]) - mean;
        covariance += glm::outerProduct(d, d);
      });
      s.normals[i] = leastSpreadDirection(covariance);
    }
  });
  return s;
}

GBufferTexels pointCloudTexels(const ScanPoints& points) {
  GBufferTexels t;
  t.positions = points.positions;
  t.normals = points.normals;
  t.colors = points.colors;
  Bounds box;
  for (glm::vec3 p : t.positions) box.add(p);
  t.center = box.center();
  float maxDistance2 = 0.0f;
  for (glm::vec3 p : t.positions) maxDistance2 = std::max(maxDistance2, glm::dot(p - t.center, p - t.center));
  t.sphereRadius = std::sqrt(maxDistance2) * 1.01f + 1e-6f;
  t.ids.resize(t.positions.size());
  for (uint32_t i = 0; i < t.ids.size(); ++i) t.ids[i] = i;
  t.resolution = 0; // no G-buffer: ids are point indices
  t.viewCount = 0;
  t.areas.resize(t.size());
  for (size_t i = 0; i < t.size(); ++i) {
    double r = points.spacing[i];
    t.areas[i] = float(3.14159265358979 * r * r / double(kPointNeighbours));
  }
  t.totalArea = 0.0;
  for (float a : t.areas) t.totalArea += a;
  // The typical spacing stands in for the texel size (what a G-buffer's resolution would be).
  t.texelSize = float(std::sqrt(t.totalArea / double(t.size())));
  return t;
}

Result<GBufferTexels> pointCloudTexels(const Scene& scene) {
  auto points = scanPoints(scene);
  if (!points) return points.error();
  return pointCloudTexels(*points);
}

} // namespace mirage::surfels
