#pragma once
// The hierarchical selections' trees (docs/render.md, "Selection"), in GpuLodNode form: per mesh
// the LOD BVH (per DAG level a BVH over the level's member groups) and the DAG group tree. Built
// from what a whole DAG (cluster_upload.cpp) and a paged asset's tables (cluster_page_pool.cpp)
// both give before any geometry; a paged asset's trees grow as its pages bring the spheres the
// tables lack (growLodLeaf, cluster_residency.cpp).
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <glm/glm.hpp>

#include "mirage/core/result.h"
#include "mirage/gpu/context.h"
#include "mirage/shaderio/cluster.h"

namespace mirage::render {

// One mesh as the trees read it.
struct LodTreeMesh {
  // Mesh-local records: the parent sphere and error (+inf: a root, whose parent sphere means
  // nothing); the self and culling spheres of the clusters `spheresKnown` marks (empty: all).
  std::span<const shaderio::GpuCluster> clusters;
  std::span<const uint8_t> spheresKnown;
  std::span<const uint32_t> memberGroup;             // per cluster: its member group, lod::kNone for roots
  std::span<const shaderio::GpuClusterLevel> levels; // the mesh's level table (clusters ordered by level)
  // Per group: its level, its member clusters (groupMembers[memberOffset[g] .. memberOffset[g + 1])),
  // and its owner, the group whose tree node holds its node (lod::kNone: the root node), of a higher
  // level. Any such owner gives a correct tree, every node's bound holding everything beneath it;
  // one whose sphere holds the group's and whose error is no smaller keeps the bounds tight.
  std::span<const uint32_t> groupLevel, memberOffset, groupMembers, groupOwner;
  std::span<const uint32_t> roots; // the root clusters
};

struct LodTrees {
  bool growable = false;                   // keeps clusterLeaf for growLodLeaf (paged assets)
  std::vector<shaderio::GpuLodNode> nodes; // per mesh: its LOD BVH, then its DAG group tree
  std::vector<uint32_t> leafClusters;      // mesh-local cluster ids of the leaves
  std::vector<uint32_t> parent;            // per node: its parent node, lod::kNone at a tree's root
  std::vector<uint32_t> clusterLeaf;       // growable: per global cluster its BVH leaf, then its DAG-tree leaf
  uint32_t lodDepth = 0;                   // deepest BVH node below its level root
  uint32_t dagDepth = 0;                   // deepest DAG-tree node
  uint32_t maxMeshNodes = 0;               // most nodes of one mesh (both trees)
};

// Appends `mesh`'s two trees to `trees` and sets gm.nodeOffset and gm.dagNodeOffset (gm.clusterOffset
// numbers its clusters in clusterLeaf). Errors, naming `context`, for a tree deeper than
// MIRAGE_LOD_MAX_DEPTH - 1.
Status appendLodTrees(const LodTreeMesh& mesh, shaderio::GpuClusterMesh& gm, LodTrees& trees,
                      const std::string& context);

// Grows leaf `node` and every node above it to hold `sphere` (object space); the nodes that changed
// are appended to `changed`. Bounds only grow: they hold whatever was ever resident beneath.
void growLodLeaf(LodTrees& trees, uint32_t node, glm::vec4 sphere, std::vector<uint32_t>& changed);

struct ClusterSceneData; // cluster_impl.h
// The trees' nodes and leaf lists into `scene` (buffers of `usage`), with their depths and sizes.
void uploadLodTrees(gpu::Context& ctx, const LodTrees& trees, VkBufferUsageFlags usage, ClusterSceneData& scene);

} // namespace mirage::render
