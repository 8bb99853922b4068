// The LOD BVH and the DAG group tree of each mesh (cluster_lod_tree.h; docs/render.md, "Selection").
#include "cluster_lod_tree.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include "cluster_impl.h"
#include "mirage/gpu/commands.h"
#include "mirage/lod/cluster_dag.h"

namespace mirage::render {

namespace sio = mirage::shaderio;

namespace {

// Smallest-effort sphere around spheres: the centre of their boxes, the farthest reach, padded so
// float rounding on the GPU never puts an enclosed sphere's nearest point before the parent's.
glm::vec4 encloseSpheres(std::span<const glm::vec4> spheres) {
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

bool holds(glm::vec4 outer, glm::vec4 inner) {
  return glm::length(glm::vec3(inner) - glm::vec3(outer)) + inner.w <= outer.w;
}

// Build-time node: a leaf (clusters sharing a member group) or up to MIRAGE_LOD_NODE_WIDTH
// children (the group tree: any number).
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

// A leaf over `members` (mesh-local clusters sharing a member group): its sphere holds every sphere
// the per-cluster test projects or culls with, as far as known: the parent sphere (the LOD bound;
// not a root's), the self sphere (a page request's frustum test) and the culling sphere. Its error
// bound is their largest parent error. Returns its id.
uint32_t appendLeafNode(std::vector<LodBuildNode>& nodes, const LodTreeMesh& m, std::span<const uint32_t> members) {
  LodBuildNode leaf;
  std::vector<glm::vec4> spheres;
  for (uint32_t c : members) {
    const sio::GpuCluster& r = m.clusters[c];
    leaf.maxParentError = std::max(leaf.maxParentError, r.parentError);
    if (!std::isinf(r.parentError)) spheres.push_back(r.parentSphere);
    if (m.spheresKnown.empty() || m.spheresKnown[c]) spheres.push_back(r.selfSphere), spheres.push_back(r.boundsSphere);
  }
  leaf.sphere = spheres.empty() ? glm::vec4(0.0f) : encloseSpheres(spheres);
  leaf.clusters.assign(members.begin(), members.end());
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

// Breadth-first layout of build nodes into `trees`: `roots` first, then each node's children in
// one contiguous run (child offsets relative to the first root), with each node's parent and each
// leaf cluster's leaf (clusterLeaf[2 * (firstCluster + c) + tree]). Returns the deepest node's
// depth below the roots.
uint32_t layoutLodNodes(const std::vector<LodBuildNode>& nodes, const std::vector<uint32_t>& roots,
                        uint32_t firstCluster, uint32_t tree, LodTrees& trees) {
  uint32_t base = uint32_t(trees.nodes.size());
  struct Item {
    uint32_t id, depth, parent;
  };
  std::vector<Item> queue; // in output order
  for (uint32_t r : roots) queue.push_back({r, 0, lod::kNone});
  trees.nodes.resize(base + roots.size());
  uint32_t maxDepth = 0;
  for (size_t q = 0; q < queue.size(); ++q) {
    Item item = queue[q];
    const LodBuildNode& n = nodes[item.id];
    uint32_t at = base + uint32_t(q);
    maxDepth = std::max(maxDepth, item.depth);
    sio::GpuLodNode g{};
    g.sphere = n.sphere;
    g.maxParentError = n.maxParentError;
    if (n.children.empty()) {
      g.leaf = 1;
      g.childOffset = uint32_t(trees.leafClusters.size());
      g.childCount = uint32_t(n.clusters.size());
      trees.leafClusters.insert(trees.leafClusters.end(), n.clusters.begin(), n.clusters.end());
      if (trees.growable)
        for (uint32_t c : n.clusters) trees.clusterLeaf[2 * size_t(firstCluster + c) + tree] = at;
    } else {
      g.childOffset = uint32_t(trees.nodes.size()) - base;
      g.childCount = uint32_t(n.children.size());
      trees.nodes.resize(trees.nodes.size() + n.children.size());
      for (uint32_t c : n.children) queue.push_back({c, item.depth + 1, at});
    }
    trees.nodes[at] = g;
    trees.parent.resize(trees.nodes.size(), lod::kNone);
    trees.parent[at] = item.parent;
  }
  return maxDepth;
}

// The LOD BVH (see GpuLodNode): per level one leaf per member group (roots: one leaf), a BVH over
// them, and the level roots stored first in level order, every node's children contiguous.
uint32_t buildLodBvh(const LodTreeMesh& m, uint32_t firstCluster, LodTrees& trees) {
  std::vector<LodBuildNode> nodes;
  std::vector<uint32_t> roots;
  for (const sio::GpuClusterLevel& level : m.levels) {
    std::vector<std::pair<uint32_t, uint32_t>> byGroup; // (member group, cluster), roots as kNone
    for (uint32_t i = level.firstCluster; i < level.firstCluster + level.clusterCount; ++i)
      byGroup.push_back({m.memberGroup[i], i});
    std::sort(byGroup.begin(), byGroup.end());
    std::vector<uint32_t> leaves, members;
    for (size_t i = 0; i < byGroup.size(); ++i) {
      members.push_back(byGroup[i].second);
      if (i + 1 == byGroup.size() || byGroup[i + 1].first != byGroup[i].first) {
        leaves.push_back(appendLeafNode(nodes, m, members));
        members.clear();
      }
    }
    roots.push_back(buildLodSubtree(nodes, std::move(leaves)));
  }
  return layoutLodNodes(nodes, roots, firstCluster, 0, trees);
}

// The DAG traversal's group tree (--selection dag, after the dissertation's DAG-TRAVERSE), in the
// same node format: one node per group, entered when the group's projected error exceeds tau
// (LOCALCUT's parent test of its member clusters). A group's node has a leaf with its member
// clusters and, as further children, the groups it owns (LodTreeMesh::groupOwner): the DAG gives a
// group several parents, the tree hangs it under exactly one, so the traversal visits it once
// without deduplication. With the owner holding the child's sphere at no smaller error (the whole
// DAG's owner is the member group of the group's first output: monotonic errors, nested spheres,
// lod/verify.h) the owner's node is entered whenever the child's must be, so the node bounds stay
// those of the groups. The root node holds the DAG roots (error +inf) and the groups without an
// owner. Spheres enclose everything beneath, so frustum culling stays conservative.
uint32_t buildDagTree(const LodTreeMesh& m, uint32_t firstCluster, LodTrees& trees) {
  std::vector<LodBuildNode> nodes;
  size_t groups = m.groupLevel.size();
  // Children of each group's node (index = group; the root's at `groups`): the groups it owns.
  std::vector<std::vector<uint32_t>> owned(groups + 1);
  for (uint32_t g = 0; g < groups; ++g) owned[m.groupOwner[g] == lod::kNone ? groups : m.groupOwner[g]].push_back(g);
  // Bottom-up: owners are of higher levels, so ascending levels build children first.
  std::vector<uint32_t> order(groups);
  for (uint32_t g = 0; g < groups; ++g) order[g] = g;
  std::stable_sort(order.begin(), order.end(),
                   [&](uint32_t a, uint32_t b) { return m.groupLevel[a] < m.groupLevel[b]; });
  std::vector<uint32_t> groupNode(groups, lod::kNone);
  auto addGroupNode = [&](uint32_t leaf, const std::vector<uint32_t>& ownedGroups) {
    if (ownedGroups.empty()) return leaf;
    std::vector<uint32_t> children{leaf};
    for (uint32_t g : ownedGroups) children.push_back(groupNode[g]);
    return appendInnerNode(nodes, std::move(children));
  };
  for (uint32_t g : order) {
    std::span<const uint32_t> members =
        m.groupMembers.subspan(m.memberOffset[g], m.memberOffset[g + 1] - m.memberOffset[g]);
    groupNode[g] = addGroupNode(appendLeafNode(nodes, m, members), owned[g]);
  }
  uint32_t root = addGroupNode(appendLeafNode(nodes, m, m.roots), owned[groups]);
  return layoutLodNodes(nodes, {root}, firstCluster, 1, trees);
}

} // namespace

Status appendLodTrees(const LodTreeMesh& mesh, sio::GpuClusterMesh& gm, LodTrees& trees, const std::string& context) {
  if (trees.growable)
    trees.clusterLeaf.resize(std::max(trees.clusterLeaf.size(), 2 * (size_t(gm.clusterOffset) + mesh.clusters.size())),
                             lod::kNone);
  gm.nodeOffset = uint32_t(trees.nodes.size());
  uint32_t depth = buildLodBvh(mesh, gm.clusterOffset, trees);
  if (depth >= MIRAGE_LOD_MAX_DEPTH)
    return Error{fmt::format("{}: LOD BVH of depth {} (at most {})", context, depth, MIRAGE_LOD_MAX_DEPTH - 1)};
  trees.lodDepth = std::max(trees.lodDepth, depth);
  gm.dagNodeOffset = uint32_t(trees.nodes.size());
  uint32_t dagDepth = buildDagTree(mesh, gm.clusterOffset, trees);
  if (dagDepth >= MIRAGE_LOD_MAX_DEPTH)
    return Error{
        fmt::format("{}: DAG group tree of depth {} (at most {})", context, dagDepth, MIRAGE_LOD_MAX_DEPTH - 1)};
  trees.dagDepth = std::max(trees.dagDepth, dagDepth);
  trees.maxMeshNodes = std::max(trees.maxMeshNodes, uint32_t(trees.nodes.size()) - gm.nodeOffset);
  return Ok{};
}

void growLodLeaf(LodTrees& trees, uint32_t node, glm::vec4 sphere, std::vector<uint32_t>& changed) {
  // Every node on the way up is made to hold the new sphere itself, not its grown child's (which
  // may be larger than what it holds): so a node that already holds it says nothing of its parent.
  for (; node != lod::kNone; node = trees.parent[node]) {
    glm::vec4& s = trees.nodes[node].sphere;
    if (holds(s, sphere)) continue;
    glm::vec4 both[2] = {s, sphere};
    s = encloseSpheres(both);
    changed.push_back(node);
  }
}

void uploadLodTrees(gpu::Context& ctx, const LodTrees& trees, VkBufferUsageFlags usage, ClusterSceneData& scene) {
  scene.lodNodes = gpu::createBufferWithData<sio::GpuLodNode>(ctx, trees.nodes, usage, "cluster LOD BVH");
  scene.leafClusters = gpu::createBufferWithData<uint32_t>(ctx, trees.leafClusters, usage, "cluster LOD BVH leaves");
  scene.lodDepth = trees.lodDepth;
  scene.dagDepth = trees.dagDepth;
  scene.maxMeshNodes = trees.maxMeshNodes;
}

} // namespace mirage::render
