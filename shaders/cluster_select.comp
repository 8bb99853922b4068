#version 460
// Flat cluster selection (--selection flat): one thread per (visible instance, cluster of the
// instance's level range from the cull pass). Linear in the clusters of the kept levels; the LOD
// BVH traversal (cluster_traverse.comp) follows the cut instead (docs/render.md).
#include "cluster_select.glsl"

layout(local_size_x = MIRAGE_CLUSTER_WORKGROUP) in;

// Cluster `local` of the range of visible instance `row`.
void selectRow(uint row, uint local) {
  VisibleInstance vi = VisibleInstanceRef(push.visibleInstanceAddress).entries[row];
  if (local >= vi.clusterCount) return;
  GpuClusterInstance inst = InstanceRef(push.instanceAddress).instances[vi.instance];
  GpuClusterMesh mesh = MeshRef(push.meshAddress).meshes[inst.mesh];
  selectCluster(vi.instance, inst, mesh, vi.firstCluster + local, push.rasterList);
}

void main() {
  // Rows are visible instances: phase 1 (push.rasterList 0) the early ones, phase 2 those appended
  // by the late-instance HZB test. With more than the 65535 rows a dispatch may have, rows loop.
  CounterRef counters = CounterRef(push.counterAddress);
  uint first = push.rasterList == 0 ? 0 : counters.counters.earlyInstances;
  uint rows = push.rasterList == 0 ? counters.counters.earlyInstances : counters.counters.visibleInstances;
  for (uint row = first + gl_WorkGroupID.y; row < rows; row += gl_NumWorkGroups.y)
    selectRow(row, gl_GlobalInvocationID.x);
}
