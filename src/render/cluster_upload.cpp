// Set-up time upload of a LodAsset for the cluster renderer: every DAG concatenated into global
// arrays (cluster table, attribute vertices, per-cluster vertex ids, packed local indices), meshes,
// instances, and materials/textures in the forward renderer's layout.
#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>
#include <meshoptimizer.h>

#include "cluster_impl.h"
#include "render_util.h"
#include "mirage/gpu/commands.h"
#include "mirage/gpu/context.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

namespace {

glm::vec4 sphere(const lod::LodBounds& b) { return {b.center, b.radius}; }

// Smallest-effort sphere around spheres: the centre of their boxes, the farthest reach, padded so
// float rounding on the GPU never puts an enclosed sphere's nearest point before the parent's.
glm::vec4 encloseSpheres(const std::vector<glm::vec4>& spheres) {
  glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
  for (const glm::vec4& s : spheres) {
    lo = glm::min(lo, glm::vec3(s) - s.w);
    hi = glm::max(hi, glm::vec3(s) + s.w);
  }
  glm::vec3 c = 0.5f * (lo + hi);
  float r = 0.0f;
  for (const glm::vec4& s : spheres) r = std::max(r, glm::length(glm::vec3(s) - c) + s.w);
  float magnitude = std::max({std::abs(c.x), std::abs(c.y), std::abs(c.z), r});
  return {c, r + 1e-5f * r + 1e-6f * magnitude};
}

// Build-time BVH node: a leaf (a member group's clusters of one level) or up to
// MIRAGE_LOD_NODE_WIDTH children.
struct LodBuildNode {
  glm::vec4 sphere{0.0f};
  float maxParentError = 0.0f;
  std::vector<uint32_t> clusters; // leaf: mesh-local cluster ids
  std::vector<uint32_t> children; // inner: build-node ids
};

// Splits `items` (build-node ids) into at most MIRAGE_LOD_NODE_WIDTH spatially coherent parts:
// the largest part is halved at the median of its centres' longest axis until there are enough.
std::vector<std::vector<uint32_t>> splitItems(const std::vector<LodBuildNode>& nodes, std::vector<uint32_t> items) {
  std::vector<std::vector<uint32_t>> parts{std::move(items)};
  while (parts.size() < MIRAGE_LOD_NODE_WIDTH) {
    auto largest =
        std::max_element(parts.begin(), parts.end(), [](const auto& a, const auto& b) { return a.size() < b.size(); });
    if (largest->size() < 2) break;
    std::vector<uint32_t> part = std::move(*largest);
    parts.erase(largest);
    glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
    for (uint32_t i : part)
      lo = glm::min(lo, glm::vec3(nodes[i].sphere)), hi = glm::max(hi, glm::vec3(nodes[i].sphere));
    glm::vec3 extent = hi - lo;
    int axis = extent.x >= extent.y && extent.x >= extent.z ? 0 : extent.y >= extent.z ? 1 : 2;
    auto mid = part.begin() + part.size() / 2;
    std::nth_element(part.begin(), mid, part.end(),
                     [&](uint32_t a, uint32_t b) { return nodes[a].sphere[axis] < nodes[b].sphere[axis]; });
    parts.emplace_back(part.begin(), mid);
    parts.emplace_back(mid, part.end());
  }
  return parts;
}

// A leaf over `members` (mesh-local clusters sharing a member group): its sphere encloses their
// parent and culling spheres, its error bound is their largest parent error. Returns its id.
uint32_t appendLeafNode(std::vector<LodBuildNode>& nodes, const sio::GpuCluster* clusters,
                        std::vector<uint32_t> members) {
  LodBuildNode leaf;
  std::vector<glm::vec4> spheres;
  for (uint32_t c : members) {
    leaf.maxParentError = std::max(leaf.maxParentError, clusters[c].parentError);
    spheres.push_back(clusters[c].parentSphere), spheres.push_back(clusters[c].boundsSphere);
  }
  leaf.sphere = encloseSpheres(spheres);
  leaf.clusters = std::move(members);
  nodes.push_back(std::move(leaf));
  return uint32_t(nodes.size() - 1);
}

// An inner node over existing `children`: its sphere encloses theirs, its error bound is their
// largest. Returns its build-node id.
uint32_t appendInnerNode(std::vector<LodBuildNode>& nodes, std::vector<uint32_t> children) {
  LodBuildNode node;
  std::vector<glm::vec4> spheres;
  for (uint32_t c : children) {
    spheres.push_back(nodes[c].sphere);
    node.maxParentError = std::max(node.maxParentError, nodes[c].maxParentError);
  }
  node.sphere = encloseSpheres(spheres);
  node.children = std::move(children);
  nodes.push_back(std::move(node));
  return uint32_t(nodes.size() - 1);
}

// An inner node over `items`, built top-down; returns its build-node id.
uint32_t buildLodSubtree(std::vector<LodBuildNode>& nodes, std::vector<uint32_t> items) {
  if (items.size() == 1) return items[0];
  std::vector<uint32_t> children;
  for (std::vector<uint32_t>& part : splitItems(nodes, std::move(items)))
    children.push_back(buildLodSubtree(nodes, std::move(part)));
  return appendInnerNode(nodes, std::move(children));
}

// Breadth-first layout of build nodes into GpuLodNodes: `roots` first, then each node's children
// in one contiguous run (child offsets relative to the first root). Returns the deepest node's
// depth below the roots.
uint32_t layoutLodNodes(const std::vector<LodBuildNode>& nodes, const std::vector<uint32_t>& roots,
                        std::vector<sio::GpuLodNode>& out, std::vector<uint32_t>& leafClusters) {
  uint32_t base = uint32_t(out.size());
  std::vector<std::pair<uint32_t, uint32_t>> queue; // (build node, depth), in output order
  for (uint32_t r : roots) queue.push_back({r, 0});
  out.resize(base + roots.size());
  uint32_t maxDepth = 0;
  for (size_t q = 0; q < queue.size(); ++q) {
    auto [id, depth] = queue[q];
    const LodBuildNode& n = nodes[id];
    maxDepth = std::max(maxDepth, depth);
    sio::GpuLodNode g{};
    g.sphere = n.sphere;
    g.maxParentError = n.maxParentError;
    if (n.children.empty()) {
      g.leaf = 1;
      g.childOffset = uint32_t(leafClusters.size());
      g.childCount = uint32_t(n.clusters.size());
      leafClusters.insert(leafClusters.end(), n.clusters.begin(), n.clusters.end());
    } else {
      g.childOffset = uint32_t(out.size()) - base;
      g.childCount = uint32_t(n.children.size());
      out.resize(out.size() + n.children.size());
      for (uint32_t c : n.children) queue.push_back({c, depth + 1});
    }
    out[base + q] = g;
  }
  return maxDepth;
}

// The LOD BVH of one mesh (see GpuLodNode): per level of `levels` (the mesh's level table) one leaf
// per member group (roots: one leaf), a BVH over them, and the roots stored first in level order,
// every node's children contiguous. Appends to `out` / `leafClusters`; returns the deepest node's
// depth below its level root.
uint32_t buildLodBvh(const sio::GpuCluster* clusters, const lod::ClusterDag& dag,
                     const std::vector<sio::GpuClusterLevel>& levels, std::vector<sio::GpuLodNode>& out,
                     std::vector<uint32_t>& leafClusters) {
  std::vector<LodBuildNode> nodes;
  std::vector<uint32_t> roots;
  for (const sio::GpuClusterLevel& level : levels) {
    std::vector<std::pair<uint32_t, uint32_t>> byGroup; // (member group, cluster), roots as kNone
    for (uint32_t i = level.firstCluster; i < level.firstCluster + level.clusterCount; ++i)
      byGroup.push_back({dag.clusters[i].group, i});
    std::sort(byGroup.begin(), byGroup.end());
    std::vector<uint32_t> leaves, members;
    for (size_t i = 0; i < byGroup.size(); ++i) {
      members.push_back(byGroup[i].second);
      if (i + 1 == byGroup.size() || byGroup[i + 1].first != byGroup[i].first) {
        leaves.push_back(appendLeafNode(nodes, clusters, members));
        members.clear();
      }
    }
    roots.push_back(buildLodSubtree(nodes, std::move(leaves)));
  }
  return layoutLodNodes(nodes, roots, out, leafClusters);
}

// The DAG traversal's group tree (--selection dag, after the dissertation's DAG-TRAVERSE), in the
// same node format: one node per group, entered when the group's projected error exceeds tau
// (LOCALCUT's parent test of its member clusters). A group's node has a leaf with its member
// clusters and, as further children, the groups whose FIRST parent cluster is one of its members:
// the DAG gives a group several parents, the tree hangs it under exactly one, so the traversal
// visits it once without deduplication. That parent is entered whenever the child must be: group g
// holds child group s's first output p, so g's error >= p's self error = s's error and g's sphere
// encloses s's (monotonic errors, nested spheres: lod/verify.h), hence projected(g) >= projected(s).
// The root node holds the DAG roots (error +inf) and the groups whose first output is a root.
// Spheres enclose everything beneath, so frustum culling stays conservative. Returns the depth.
uint32_t buildDagTree(const sio::GpuCluster* clusters, const lod::ClusterDag& dag, std::vector<sio::GpuLodNode>& out,
                      std::vector<uint32_t>& leafClusters) {
  std::vector<LodBuildNode> nodes;
  // Children of each group's node (index = group; the root's at dag.groups.size()): groups owned.
  std::vector<std::vector<uint32_t>> owned(dag.groups.size() + 1);
  for (uint32_t g = 0; g < dag.groups.size(); ++g) {
    uint32_t firstParent = dag.groupParents[dag.groups[g].parentOffset];
    uint32_t owner = dag.clusters[firstParent].group;
    owned[owner == lod::kNone ? dag.groups.size() : owner].push_back(g);
  }
  // Bottom-up: an owned group's parents are one level up, so ascending levels build children first.
  std::vector<uint32_t> order(dag.groups.size());
  for (uint32_t g = 0; g < order.size(); ++g) order[g] = g;
  std::stable_sort(order.begin(), order.end(),
                   [&](uint32_t a, uint32_t b) { return dag.groups[a].level < dag.groups[b].level; });
  std::vector<uint32_t> groupNode(dag.groups.size() + 1, lod::kNone);
  auto addGroupNode = [&](uint32_t leaf, const std::vector<uint32_t>& ownedGroups) {
    if (ownedGroups.empty()) return leaf;
    std::vector<uint32_t> children{leaf};
    for (uint32_t g : ownedGroups) children.push_back(groupNode[g]);
    return appendInnerNode(nodes, std::move(children));
  };
  for (uint32_t g : order) {
    const lod::Group& group = dag.groups[g];
    const uint32_t* members = &dag.groupChildren[group.childOffset];
    uint32_t leaf = appendLeafNode(nodes, clusters, {members, members + group.childCount});
    groupNode[g] = addGroupNode(leaf, owned[g]);
  }
  uint32_t rootLeaf = appendLeafNode(nodes, clusters, dag.roots);
  uint32_t root = addGroupNode(rootLeaf, owned[dag.groups.size()]);
  return layoutLodNodes(nodes, {root}, out, leafClusters);
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
  return g;
}

Result<ClusterSceneData> uploadClusterScene(Context& ctx, const lod::LodAsset& asset) {
  const Scene& scene = asset.scene;
  if (asset.dags.size() != scene.meshes.size())
    return Error{fmt::format("{}: {} DAGs for {} meshes", scene.source, asset.dags.size(), scene.meshes.size())};
  ClusterSceneData d;
  std::vector<sio::GpuCluster> clusters;
  std::vector<sio::GpuClusterCone> cones;
  std::vector<sio::GpuClusterVertex> vertices;
  std::vector<uint32_t> clusterVertices;
  std::vector<uint8_t> indexBytes;
  std::vector<sio::GpuClusterMesh> meshes;
  std::vector<sio::GpuClusterLevel> levels;
  std::vector<sio::GpuLodNode> lodNodes;
  std::vector<uint32_t> leafClusters;
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
      clusters.push_back(g);
      cones.push_back(clusterCone(positions, local));
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
    gm.nodeOffset = uint32_t(lodNodes.size());
    std::vector<sio::GpuClusterLevel> meshLevels(levels.begin() + gm.levelOffset, levels.end());
    uint32_t depth = buildLodBvh(&clusters[gm.clusterOffset], dag, meshLevels, lodNodes, leafClusters);
    if (depth >= MIRAGE_LOD_MAX_DEPTH)
      return Error{fmt::format("{}: mesh '{}': LOD BVH of depth {} (at most {})", scene.source, scene.meshes[m].name,
                               depth, MIRAGE_LOD_MAX_DEPTH - 1)};
    d.lodDepth = std::max(d.lodDepth, depth);
    gm.dagNodeOffset = uint32_t(lodNodes.size());
    uint32_t dagDepth = buildDagTree(&clusters[gm.clusterOffset], dag, lodNodes, leafClusters);
    if (dagDepth >= MIRAGE_LOD_MAX_DEPTH)
      return Error{fmt::format("{}: mesh '{}': DAG group tree of depth {} (at most {})", scene.source,
                               scene.meshes[m].name, dagDepth, MIRAGE_LOD_MAX_DEPTH - 1)};
    d.dagDepth = std::max(d.dagDepth, dagDepth);
    d.maxMeshNodes = std::max(d.maxMeshNodes, uint32_t(lodNodes.size()) - gm.nodeOffset);
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
  d.cones = createBufferWithData<sio::GpuClusterCone>(ctx, cones, kStorage, "cluster cones");
  d.lodNodes = createBufferWithData<sio::GpuLodNode>(ctx, lodNodes, kStorage, "cluster LOD BVH");
  d.leafClusters = createBufferWithData<uint32_t>(ctx, leafClusters, kStorage, "cluster LOD BVH leaves");
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
