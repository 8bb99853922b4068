// Set-up time upload of a LodAsset for the cluster renderer: every DAG concatenated into global
// arrays (cluster table, attribute vertices, per-cluster vertex ids, packed local indices), meshes,
// instances, and materials/textures in the forward renderer's layout.
#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <meshoptimizer.h>

#include "cluster_impl.h"
#include "cluster_lod_tree.h"
#include "render_util.h"
#include "mirage/gpu/commands.h"
#include "mirage/gpu/context.h"
#include "mirage/shaderio/lod_paging.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

namespace {

glm::vec4 sphere(const lod::LodBounds& b) { return {b.center, b.radius}; }

// The trees of a whole DAG (its records the last of `clusters`, its levels the last of `levels`):
// every sphere known, each group owned by the member group of its first output (none for a root).
Status appendDagTrees(const lod::ClusterDag& dag, const std::vector<sio::GpuCluster>& clusters,
                      const std::vector<sio::GpuClusterLevel>& levels, sio::GpuClusterMesh& gm, LodTrees& trees,
                      const std::string& context) {
  std::vector<uint32_t> memberGroup, groupLevel, memberOffset{0}, groupMembers, groupOwner;
  for (const lod::Cluster& c : dag.clusters) memberGroup.push_back(c.group);
  for (const lod::Group& g : dag.groups) {
    groupLevel.push_back(g.level);
    groupMembers.insert(groupMembers.end(), dag.groupChildren.begin() + g.childOffset,
                        dag.groupChildren.begin() + g.childOffset + g.childCount);
    memberOffset.push_back(uint32_t(groupMembers.size()));
    groupOwner.push_back(dag.clusters[dag.groupParents[g.parentOffset]].group);
  }
  LodTreeMesh mesh;
  mesh.clusters = std::span(clusters).subspan(gm.clusterOffset, gm.clusterCount);
  mesh.memberGroup = memberGroup;
  mesh.levels = std::span(levels).subspan(gm.levelOffset, gm.levelCount);
  mesh.groupLevel = groupLevel;
  mesh.memberOffset = memberOffset;
  mesh.groupMembers = groupMembers;
  mesh.groupOwner = groupOwner;
  mesh.roots = dag.roots;
  return appendLodTrees(mesh, gm, trees, context);
}

} // namespace

sio::GpuClusterCone clusterCone(std::span<const glm::vec3> positions, std::span<const uint8_t> localIndices) {
  std::vector<uint32_t> indices(localIndices.begin(), localIndices.end());
  meshopt_Bounds b = meshopt_computeClusterBounds(indices.data(), indices.size(), &positions[0].x, positions.size(),
                                                  sizeof(glm::vec3));
  sio::GpuClusterCone cone{};
  cone.axisCutoff = {b.cone_axis[0], b.cone_axis[1], b.cone_axis[2], b.cone_cutoff};
  cone.apex = {b.cone_apex[0], b.cone_apex[1], b.cone_apex[2], 0.0f};
  if (!(glm::length(glm::vec3(cone.axisCutoff)) > 0.5f)) cone.axisCutoff.w = 1.0f;
  return cone;
}

float clusterMaxEdge(std::span<const glm::vec3> positions, std::span<const uint8_t> localIndices) {
  // One square root: the correctly rounded root is monotonic, so the root of the largest square is
  // the largest root, bit for bit.
  double longestSquared = 0.0;
  for (size_t t = 0; t + 2 < localIndices.size(); t += 3)
    for (int k = 0; k < 3; ++k) {
      glm::dvec3 d = glm::dvec3(positions[localIndices[t + k]]) - glm::dvec3(positions[localIndices[t + (k + 1) % 3]]);
      longestSquared = std::max(longestSquared, glm::dot(d, d));
    }
  double longest = std::sqrt(longestSquared);
  float f = float(longest);
  return double(f) < longest ? std::nextafter(f, std::numeric_limits<float>::infinity()) : f;
}

sio::GpuCluster clusterRecord(const lod::Cluster& c, uint32_t mesh) {
  sio::GpuCluster g{};
  g.selfSphere = sphere(c.self);
  g.parentSphere = sphere(c.parent);
  g.boundsSphere = sphere(c.bounds);
  g.selfError = c.self.error;
  g.parentError = c.group == lod::kNone ? std::numeric_limits<float>::infinity() : c.parent.error;
  g.vertexOffset = c.vertexOffset;
  g.triangleOffset = c.triangleOffset;
  g.vertexCount = c.vertexCount;
  g.triangleCount = c.triangleCount;
  g.mesh = mesh;
  g.level = c.level;
  g.maxEdge = std::numeric_limits<float>::infinity(); // the callers measure it from the vertices
  g.cone.axisCutoff.w = 1.0f;                         // never culled: the callers make the cone
  g.page = g.childPage = MIRAGE_PAGE_NONE;
  return g;
}

Result<ClusterSceneData> uploadClusterScene(Context& ctx, const lod::LodAsset& asset) {
  const Scene& scene = asset.scene;
  if (asset.dags.size() != scene.meshes.size())
    return Error{fmt::format("{}: {} DAGs for {} meshes", scene.source, asset.dags.size(), scene.meshes.size())};
  ClusterSceneData d;
  std::vector<sio::GpuCluster> clusters;
  std::vector<sio::GpuClusterVertex> vertices;
  std::vector<uint32_t> clusterVertices;
  std::vector<uint8_t> indexBytes;
  std::vector<sio::GpuClusterMesh> meshes;
  std::vector<sio::GpuClusterLevel> levels;
  LodTrees trees;
  std::vector<Bounds> meshBounds;
  for (size_t m = 0; m < asset.dags.size(); ++m) {
    const lod::ClusterDag& dag = asset.dags[m];
    uint32_t vertexBase = uint32_t(vertices.size());
    uint32_t clusterVertexBase = uint32_t(clusterVertices.size());
    uint32_t triangleBase = uint32_t(indexBytes.size() / 3);
    Bounds bounds;
    for (size_t v = 0; v < dag.vertexPosition.size(); ++v) {
      sio::GpuClusterVertex g{};
      g.position = dag.positions[dag.vertexPosition[v]];
      g.normal = v < dag.normals.size() ? dag.normals[v] : glm::vec3(0, 1, 0);
      g.uv = v < dag.uv0.size() ? dag.uv0[v] : glm::vec2(0.0f);
      bounds.add(g.position);
      vertices.push_back(g);
    }
    for (uint32_t id : dag.clusterVertices) clusterVertices.push_back(vertexBase + id);
    indexBytes.insert(indexBytes.end(), dag.clusterIndices.begin(), dag.clusterIndices.end());
    sio::GpuClusterMesh gm{};
    gm.sphere = glm::vec4(bounds.empty() ? glm::vec3(0.0f) : bounds.center(), bounds.radius());
    gm.clusterOffset = uint32_t(clusters.size());
    gm.clusterCount = uint32_t(dag.clusters.size());
    gm.material = scene.meshes[m].material;
    for (const lod::Cluster& c : dag.clusters) {
      if (c.triangleCount > MIRAGE_CLUSTER_MAX_TRIANGLES || c.vertexCount > MIRAGE_CLUSTER_MAX_VERTICES)
        return Error{fmt::format("{}: mesh '{}' has a cluster of {} triangles / {} vertices; the renderer takes "
                                 "at most {} / {} (rebuild with --cluster-triangles {})",
                                 scene.source, scene.meshes[m].name, c.triangleCount, c.vertexCount,
                                 MIRAGE_CLUSTER_MAX_TRIANGLES, MIRAGE_CLUSTER_MAX_VERTICES,
                                 MIRAGE_CLUSTER_MAX_TRIANGLES)};
      // The cone and longest edge from the cluster's own vertices (as a page gives them,
      // cluster_residency.cpp).
      std::vector<glm::vec3> positions(c.vertexCount);
      for (uint32_t v = 0; v < c.vertexCount; ++v)
        positions[v] = dag.positions[dag.vertexPosition[dag.clusterVertices[c.vertexOffset + v]]];
      std::span<const uint8_t> local{&dag.clusterIndices[size_t(c.triangleOffset) * 3], size_t(c.triangleCount) * 3};
      sio::GpuCluster g = clusterRecord(c, uint32_t(m));
      g.vertexOffset += clusterVertexBase;
      g.triangleOffset += triangleBase;
      g.maxEdge = clusterMaxEdge(positions, local);
      g.cone = clusterCone(positions, local);
      g.cluster = uint32_t(clusters.size());
      clusters.push_back(g);
    }
    // Level table and reach (see GpuClusterMesh): clusters come ordered by level from the builder.
    gm.levelOffset = uint32_t(levels.size());
    glm::vec3 centre(gm.sphere);
    for (uint32_t i = 0; i < gm.clusterCount; ++i) {
      const lod::Cluster& c = dag.clusters[i];
      if (i > 0 && c.level < dag.clusters[i - 1].level)
        return Error{
            fmt::format("{}: mesh '{}': clusters are not ordered by level", scene.source, scene.meshes[m].name)};
      if (i == 0 || c.level != dag.clusters[i - 1].level)
        levels.push_back({i, 0, std::numeric_limits<float>::infinity(), 0.0f});
      sio::GpuClusterLevel& l = levels.back();
      l.clusterCount++;
      l.minSelfError = std::min(l.minSelfError, c.self.error);
      l.maxParentError = std::max(l.maxParentError, clusters[gm.clusterOffset + i].parentError);
      for (const lod::LodBounds* b : {&c.self, &c.parent})
        gm.reach = std::max(gm.reach, glm::length(b->center - centre) + b->radius);
    }
    gm.levelCount = uint32_t(levels.size()) - gm.levelOffset;
    if (Status st = appendDagTrees(dag, clusters, levels, gm, trees,
                                   fmt::format("{}: mesh '{}'", scene.source, scene.meshes[m].name));
        !st)
      return st.error();
    d.maxMeshClusters = std::max(d.maxMeshClusters, gm.clusterCount);
    meshes.push_back(gm);
    meshBounds.push_back(bounds);
  }
  if (clusters.empty()) return Error{scene.source + ": the asset has no clusters"};
  // Padding of one full cluster: the indirect backend's vertex shader and lavapipe's unmasked SIMD
  // lanes may read up to MAX_TRIANGLES triangles past the last cluster's start.
  indexBytes.resize(indexBytes.size() + 3 * MIRAGE_CLUSTER_MAX_TRIANGLES, 0);
  // Four local indices per word: shaders need no 8-bit storage feature to read them.
  std::vector<uint32_t> packed((indexBytes.size() + 3) / 4, 0u);
  for (size_t i = 0; i < indexBytes.size(); ++i) packed[i / 4] |= uint32_t(indexBytes[i]) << (8 * (i % 4));

  if (Status st = uploadClusterInstances(ctx, scene, meshes, meshBounds, d); !st) return st.error();
  constexpr VkBufferUsageFlags kStorage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  d.vertices = createBufferWithData<sio::GpuClusterVertex>(ctx, vertices, kStorage, "cluster vertices");
  d.clusterVertices = createBufferWithData<uint32_t>(ctx, clusterVertices, kStorage, "cluster vertex ids");
  d.indices = createBufferWithData<uint32_t>(ctx, packed, kStorage, "cluster local indices");
  d.clusters = createBufferWithData<sio::GpuCluster>(ctx, clusters, kStorage, "cluster table");
  d.levels = createBufferWithData<sio::GpuClusterLevel>(ctx, levels, kStorage, "cluster levels");
  uploadLodTrees(ctx, trees, kStorage, d);
  d.clusterCount = uint32_t(clusters.size());
  return d;
}

uint32_t clusterInstanceFlags(const Material& material, const glm::mat4& model) {
  return (material.doubleSided ? MIRAGE_INSTANCE_DOUBLE_SIDED : 0u) |
         (glm::determinant(glm::mat3(model)) < 0.0f ? MIRAGE_INSTANCE_MIRRORED : 0u) |
         (material.alphaMode == AlphaMode::Mask ? MIRAGE_INSTANCE_ALPHA_MASK : 0u) |
         (material.alphaMode == AlphaMode::Blend ? MIRAGE_INSTANCE_ALPHA_BLEND : 0u);
}

Status uploadClusterInstances(Context& ctx, const Scene& scene, std::vector<sio::GpuClusterMesh> meshes,
                              const std::vector<Bounds>& meshBounds, ClusterSceneData& d) {
  std::vector<Material> mats = scene.materials;
  if (mats.empty()) mats.push_back(Material{});

  std::vector<sio::GpuClusterInstance> instances;
  for (const Instance& inst : scene.instances) {
    if (inst.mesh >= meshes.size()) continue;
    const Material& mat = mats[std::min<size_t>(meshes[inst.mesh].material, mats.size() - 1)];
    sio::GpuClusterInstance g{};
    g.model = inst.transform;
    g.normalMatrix = glm::transpose(glm::inverse(inst.transform));
    g.maxScale = maxAxisScale(inst.transform);
    glm::vec4 s = meshes[inst.mesh].sphere;
    g.sphere = glm::vec4(glm::vec3(inst.transform * glm::vec4(glm::vec3(s), 1.0f)), s.w * g.maxScale);
    g.mesh = inst.mesh;
    // Bits past 2^32 wrap: the renderer turns occlusion culling off for such scenes.
    g.historyOffset = uint32_t(d.instancedClusters);
    g.flags = clusterInstanceFlags(mat, inst.transform); // alpha modes per instance (the material is per mesh)
    instances.push_back(g);
    d.instancedClusters += meshes[inst.mesh].clusterCount;
    if (mat.alphaMode == AlphaMode::Blend) d.blendInstancedClusters += meshes[inst.mesh].clusterCount;
    d.hasMask |= mat.alphaMode == AlphaMode::Mask;
    d.instanceClusters.push_back(meshes[inst.mesh].clusterCount);
    d.worldBounds.add(transformBounds(meshBounds[inst.mesh], inst.transform));
  }
  if (instances.empty()) return Error{scene.source + ": the scene has no instances"};
  for (auto& m : meshes) m.material = std::min<uint32_t>(m.material, uint32_t(mats.size() - 1));

  constexpr VkBufferUsageFlags kStorage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  d.meshes = createBufferWithData<sio::GpuClusterMesh>(ctx, meshes, kStorage, "cluster meshes");
  d.instances = createBufferWithData<sio::GpuClusterInstance>(ctx, instances, kStorage, "cluster instances");
  d.materials = uploadMaterials(ctx, mats, scene.textures.size(), d.mapTransforms, "cluster materials");
  d.resolveSpecialization = materialMapSpecialization(mats, scene.textures.size());
  d.lights = uploadLights(ctx, scene.lights, "cluster point lights");
  d.lightCount = uint32_t(scene.lights.size());
  d.textures = uploadTextures(ctx, scene);
  d.sampler = makeSampler(ctx, VK_FILTER_LINEAR);
  d.nearestSampler = makeSampler(ctx, VK_FILTER_NEAREST);
  d.instanceCount = uint32_t(instances.size());
  return Ok{};
}

} // namespace mirage::render
