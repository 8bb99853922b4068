#include "mirage/lod/cluster_pvs.h"

#include <string>

namespace mirage::lod {

uint64_t sourceTriangleCount(const Scene& scene, const std::vector<std::vector<uint32_t>>& sourceClusters) {
  uint64_t n = 0;
  for (const Instance& inst : scene.instances)
    if (inst.mesh < sourceClusters.size()) n += sourceClusters[inst.mesh].size();
  return n;
}

void propagateVisibility(const ClusterDag& dag, std::vector<uint8_t>& visible) {
  // 0 = not computed, 1 = no visible child, 2 = a visible child. Clusters are ordered by level and a
  // generating group's children lie one level below, so they are final when a parent asks.
  std::vector<uint8_t> groupState(dag.groups.size(), 0);
  for (size_t c = 0; c < dag.clusters.size(); ++c) {
    uint32_t g = dag.clusters[c].generatingGroup;
    if (g == kNone) continue;
    if (groupState[g] == 0) {
      const Group& group = dag.groups[g];
      bool any = false;
      for (uint32_t k = 0; k < group.childCount && !any; ++k) any = visible[dag.groupChildren[group.childOffset + k]];
      groupState[g] = any ? 2 : 1;
    }
    visible[c] = groupState[g] == 2;
  }
}

Result<ClusterPvs> clusterPvs(const Scene& scene, const std::vector<ClusterDag>& dags,
                              const std::vector<std::vector<uint32_t>>& sourceClusters, std::span<const uint32_t> ids) {
  ClusterPvs out;
  out.instanceBitOffset.assign(scene.instances.size(), kPvsInstanceCulled);
  uint64_t begin = 0, bitCount = 0;
  size_t next = 0; // ids are sorted and instances are contiguous ranges: one merge-like pass
  std::vector<uint8_t> visible;
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    uint32_t mesh = scene.instances[i].mesh;
    if (mesh >= sourceClusters.size() || mesh >= dags.size())
      return Error{"instance " + std::to_string(i) + ": mesh " + std::to_string(mesh) +
                   " has no source-triangle map (baked before maps were recorded: run mirage build again)"};
    const std::vector<uint32_t>& map = sourceClusters[mesh];
    uint64_t end = begin + map.size();
    size_t first = next;
    while (next < ids.size() && ids[next] < end) ++next;
    if (next > first) {
      const ClusterDag& dag = dags[mesh];
      visible.assign(dag.clusters.size(), 0);
      bool any = false;
      for (size_t k = first; k < next; ++k) {
        uint32_t cluster = map[size_t(ids[k] - begin)];
        if (cluster == kNone) continue; // a degenerate source triangle: covers no pixel
        visible[cluster] = 1;
        any = true;
      }
      if (any) {
        propagateVisibility(dag, visible);
        if (bitCount + dag.clusters.size() >= kPvsInstanceCulled)
          return Error{"cluster PVS: more than 2^32 (instance, cluster) bits in one cell"};
        out.instanceBitOffset[i] = uint32_t(bitCount);
        out.clusterBits.resize((bitCount + dag.clusters.size() + 31) / 32, 0u);
        for (size_t c = 0; c < visible.size(); ++c, ++bitCount)
          if (visible[c]) {
            out.clusterBits[bitCount / 32] |= 1u << (bitCount % 32);
            ++out.visibleClusters;
          }
        ++out.visibleInstances;
      }
    }
    begin = end;
  }
  if (next < ids.size())
    return Error{"PVS triangle " + std::to_string(ids[next]) + " is outside the scene's " + std::to_string(begin) +
                 " source triangles"};
  return out;
}

} // namespace mirage::lod
