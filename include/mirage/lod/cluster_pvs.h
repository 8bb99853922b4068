#pragma once
// Cluster-level PVS (docs/visibility.md, "Cluster PVS"): which (instance, cluster) pairs of a baked
// cluster-LOD scene a view cell can see, derived from the cell's triangle PVS (global source
// triangle IDs, instance-major as vis::triangleOffsets) and each mesh's source-triangle map:
//   - a level-0 cluster is visible when any source triangle it holds is in the PVS;
//   - a coarser cluster is visible when any child of the group it was simplified from is visible
//     (it replaces that whole group, so it must be drawn wherever any part of the group shows);
//   - an instance with no visible cluster is culled before cluster selection.
// Any LOD cut then covers every visible surface with visible clusters: a cut cluster that covers
// a visible level-0 cluster is its ancestor through generating groups, and the rule marks every
// such ancestor.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "mirage/core/result.h"
#include "mirage/lod/cluster_dag.h"
#include "mirage/core/scene.h"

namespace mirage::lod {

inline constexpr uint32_t kPvsInstanceCulled = ~0u;

// The per-cell set in the layout the renderer uploads: per scene instance the first bit of its
// clusters in `clusterBits` (bit b of word b / 32), or kPvsInstanceCulled; the visible instances'
// ranges are packed one after another (each mesh's cluster count bits).
struct ClusterPvs {
  std::vector<uint32_t> instanceBitOffset; // per instance
  std::vector<uint32_t> clusterBits;
  uint32_t visibleInstances = 0;
  uint64_t visibleClusters = 0; // set bits
  uint64_t bytes() const { return (instanceBitOffset.size() + clusterBits.size()) * 4; }
  bool visible(uint32_t instance, uint32_t meshCluster) const {
    uint32_t base = instanceBitOffset[instance];
    if (base == kPvsInstanceCulled) return false;
    uint64_t bit = uint64_t(base) + meshCluster;
    return (clusterBits[bit / 32] >> (bit % 32)) & 1u;
  }
};

// Source triangles of the scene the asset was baked from (what a triangle PVS counts): the sum
// over instances of their mesh's source-triangle map size. 0 when the maps are missing.
uint64_t sourceTriangleCount(const Scene& scene, const std::vector<std::vector<uint32_t>>& sourceClusters);

// The cell's cluster PVS. `sortedTriangleIds` are global source triangle IDs (sorted, unique);
// `sourceClusters[m]` maps mesh m's source triangles to level-0 clusters (LodAsset). Errors when an
// ID is outside the scene or an instance's mesh has no map.
Result<ClusterPvs> clusterPvs(const Scene& scene, const std::vector<ClusterDag>& dags,
                              const std::vector<std::vector<uint32_t>>& sourceClusters,
                              std::span<const uint32_t> sortedTriangleIds);

// Marks, in `visible` (one flag per cluster of `dag`, level-0 entries set by the caller), every
// coarser cluster whose generating group has a visible child. Groups are processed in level order.
void propagateVisibility(const ClusterDag& dag, std::vector<uint8_t>& visible);

} // namespace mirage::lod
