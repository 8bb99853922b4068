#version 460
// Per-instance culling: visible instances are appended and counted into the selection dispatch's
// y dimension, so the cluster pass never visits an off-screen instance's clusters.
#include "cluster_common.glsl"

layout(local_size_x = MIRAGE_CLUSTER_WORKGROUP) in;

void main() {
  uint i = gl_GlobalInvocationID.x;
  CounterRef counters = CounterRef(push.counterAddress);
  if (i == 0) {
    counters.counters.selectArgs[0] = (push.maxMeshClusters + MIRAGE_CLUSTER_WORKGROUP - 1) / MIRAGE_CLUSTER_WORKGROUP;
    counters.counters.selectArgs[2] = 1;
  }
  ClusterFrame f = FrameRef(push.frameAddress).frame;
  if (i >= f.instanceCount) return;
  GpuClusterInstance inst = InstanceRef(push.instanceAddress).instances[i];
  if ((f.flags & MIRAGE_FRAME_FRUSTUM_CULL) != 0 && !sphereVisible(inst.sphere)) return;
  uint slot = atomicAdd(counters.counters.visibleInstances, 1);
  atomicAdd(counters.counters.selectArgs[1], 1);
  UintRef(push.visibleInstanceAddress).data[slot] = i;
}
