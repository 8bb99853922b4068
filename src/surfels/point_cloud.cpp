#include "mirage/surfels/point_cloud.h"

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

} // namespace

bool isPointCloud(const Scene& scene) {
  if (scene.instancedTriangleCount() > 0) return false;
  for (const Instance& inst : scene.instances)
    if (inst.mesh < scene.meshes.size() && !scene.meshes[inst.mesh].positions.empty()) return true;
  return false;
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
      s.positions.push_back(glm::vec3(inst.transform * glm::vec4(m.positions[i], 1.0f)));
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
