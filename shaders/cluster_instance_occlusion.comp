#version 460
// Late instances (visible, but no pixel last frame) against the HZB of pass 1: the ones that may
// be visible are appended to the visible instances for the phase-2 selection, the rest skip
// selection altogether. Conservative like the cluster test (cluster_occlusion.comp).
#include "cluster_common.glsl"
#include "cluster_traversal.glsl"

layout(local_size_x = MIRAGE_CLUSTER_WORKGROUP) in;

void main() {
  uint i = gl_GlobalInvocationID.x;
  ClusterFrame f = FrameRef(push.frameAddress).frame;
  CounterRef counters = CounterRef(push.counterAddress);
  if (i >= counters.counters.lateInstances) return;
  VisibleInstance entry = VisibleInstanceRef(f.lateInstanceAddress).entries[i];
  if (!hzbVisible(InstanceRef(push.instanceAddress).instances[entry.instance].sphere)) {
    atomicAdd(counters.counters.instancesOcclusionCulled, 1);
    return;
  }
  uint slot = atomicAdd(counters.counters.visibleInstances, 1);
  VisibleInstanceRef(push.visibleInstanceAddress).entries[slot] = entry;
  if ((f.flags & MIRAGE_FRAME_HIERARCHY) != 0) queueLevelRoots(1, slot, entry.levels);
}
