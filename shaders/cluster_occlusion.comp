#version 460
// Pass-2 cull: every selected cluster not drawn in pass 1 is tested against the HZB built from
// pass 1's depth; the ones that may be visible are drawn in pass 2. Conservative: the HZB holds
// only surfaces drawn this frame, so a cluster behind it is hidden whatever pass 1 missed.
#include "cluster_common.glsl"

layout(local_size_x = MIRAGE_CLUSTER_WORKGROUP) in;

// Thread index of a 2D-split 1D dispatch (x below the 65535 limit, as the raster dispatches).
uint flatThread() {
  return (gl_WorkGroupID.y * MIRAGE_CLUSTER_DISPATCH_X + gl_WorkGroupID.x) * MIRAGE_CLUSTER_WORKGROUP +
         gl_LocalInvocationIndex;
}

void main() {
  uint i = flatThread();
  ClusterFrame f = FrameRef(push.frameAddress).frame;
  CounterRef counters = CounterRef(push.counterAddress);
  if (i >= min(counters.counters.candidates, f.visibleCapacity)) return;
  VisibleCluster vc = VisibleRef(f.candidateAddress).visible[i];
  GpuCluster c = ClusterRef(push.clusterAddress).clusters[vc.cluster];
  GpuClusterInstance inst = InstanceRef(push.instanceAddress).instances[vc.instance];
  vec4 s = worldSphere(c, inst);
  if (!hzbVisible(s)) {
    atomicAdd(counters.counters.clustersOcclusionCulled, 1);
    return;
  }
  emitCluster(vc, s, c, inst, f);
}
