#pragma once
// Private state of ClusterRenderer, shared by cluster_upload.cpp (scene data, set-up time) and
// cluster_renderer.cpp (pipelines and the per-frame command sequence).
#include <vector>

#include "mirage/gpu/memory.h"
#include "mirage/gpu/query.h"
#include "mirage/render/cluster_renderer.h"
#include "mirage/shaderio/cluster.h"

namespace mirage::render {

// Everything uploaded once per asset (docs/render.md, "Data layout").
struct ClusterSceneData {
  gpu::Buffer clusters;        // GpuCluster[], all meshes' DAGs concatenated
  gpu::Buffer vertices;        // GpuClusterVertex[], all attribute vertices
  gpu::Buffer clusterVertices; // uint[], attribute-vertex ids rebased to `vertices`
  gpu::Buffer indices;         // uint[], local 8-bit indices packed 4 per word
  gpu::Buffer meshes;          // GpuClusterMesh[]
  gpu::Buffer levels;          // GpuClusterLevel[], per mesh (GpuClusterMesh::levelOffset)
  gpu::Buffer instances;       // GpuClusterInstance[]
  gpu::Buffer materials;       // GpuMaterial[] (the forward renderer's layout)
  gpu::Buffer cones;           // GpuClusterCone[], parallel to `clusters`
  gpu::Buffer lodNodes;        // GpuLodNode[], per mesh (GpuClusterMesh::nodeOffset)
  gpu::Buffer leafClusters;    // uint[]: mesh-local cluster ids of the LOD BVH's leaves
  std::vector<gpu::Image> textures;
  gpu::Unique<VkSampler> sampler;        // trilinear, repeat: material textures
  gpu::Unique<VkSampler> nearestSampler; // the integer visibility image
  uint32_t clusterCount = 0;
  uint32_t instanceCount = 0;
  uint32_t maxMeshClusters = 0;
  uint32_t maxMeshNodes = 0;              // largest LOD BVH of one mesh (nodes)
  uint32_t lodDepth = 0;                  // deepest LOD BVH node below its level root (traversal passes - 1)
  uint32_t dagDepth = 0;                  // deepest node of the DAG group trees (--selection dag: passes - 1)
  uint64_t instancedClusters = 0;         // sum over instances of their mesh's clusters (history bits)
  uint64_t blendInstancedClusters = 0;    // the same over BLEND instances: 0 = no transparency passes
  bool hasMask = false;                   // a MASK instance: the compute raster adds the masked kernel
  std::vector<uint32_t> instanceClusters; // per GPU instance: its mesh's cluster count (history ranges)
  Bounds worldBounds;
};

// Uploads `asset`; errors for clusters beyond the mesh-shader limits or an empty scene.
Result<ClusterSceneData> uploadClusterScene(gpu::Context& ctx, const lod::LodAsset& asset);

} // namespace mirage::render
