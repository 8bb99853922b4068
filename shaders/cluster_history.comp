#version 460
// Visibility history for the next frame: every cluster drawn this frame (both passes, both lists)
// is tested against the HZB of the final depth; the ones that may be visible set their bit, so
// next frame's pass 1 draws them and clusters hidden now wait for its occlusion test.
#include "cluster_common.glsl"

layout(local_size_x = MIRAGE_CLUSTER_WORKGROUP) in;

// Thread index of a 2D-split 1D dispatch (x below the 65535 limit, as the raster dispatches).
uint flatThread() {
  return (gl_WorkGroupID.y * MIRAGE_CLUSTER_DISPATCH_X + gl_WorkGroupID.x) * MIRAGE_CLUSTER_WORKGROUP +
         gl_LocalInvocationIndex;
}

void main() {
  uint i = flatThread();
  CounterRef counters = CounterRef(push.counterAddress);
  uint up = counters.counters.listEnd[MIRAGE_LIST_UP], down = counters.counters.listEnd[MIRAGE_LIST_DOWN];
  if (i >= up + down) return;
  uint entry = i < up ? listEntry(MIRAGE_LIST_UP, i) : listEntry(MIRAGE_LIST_DOWN, i - up);
  VisibleCluster vc = VisibleRef(push.visibleAddress).visible[entry];
  GpuCluster c = ClusterRef(push.clusterAddress).clusters[vc.cluster];
  GpuClusterInstance inst = InstanceRef(push.instanceAddress).instances[vc.instance];
  if (!hzbVisible(worldSphere(c, inst))) return;
  uint meshLocal = vc.cluster - MeshRef(push.meshAddress).meshes[inst.mesh].clusterOffset;
  setHistoryBit(inst, meshLocal);
  atomicAdd(counters.counters.historyKept, 1);
}
