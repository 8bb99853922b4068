#version 460
// Flat cluster selection (--selection flat): one thread per (visible instance, cluster of the
// instance's level range from the cull pass). Linear in the clusters of the kept levels; the LOD
// BVH traversal (cluster_traverse.comp) follows the cut instead (docs/render.md).
// Without occlusion culling, the last workgroup to finish writes pass 1's raster arguments instead
// of a one-thread pass after it: on an H100 each dependent dispatch and its barrier cost about
// 4.6 us of a 2500-instance frame's 0.17 ms. (With occlusion a frame can have no early instance,
// so no workgroup would run: the arguments pass stays, cluster_args.comp.) Without any visible
// instance no workgroup runs either, and the zeroed counters are the empty lists' arguments.
#include "cluster_select.glsl"
#include "cluster_args.glsl"

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
  if (push.rasterList != 0 || (FrameRef(push.frameAddress).frame.flags & MIRAGE_FRAME_OCCLUSION) != 0) return;
  // Every workgroup makes its appends visible before it counts itself done, so the last one to
  // count sees all of them (the counts read atomically: other workgroups' increments, not a copy
  // cached before them).
  memoryBarrierBuffer();
  barrier();
  if (gl_LocalInvocationIndex != 0) return;
  if (atomicAdd(counters.counters.selectDone, 1) != gl_NumWorkGroups.x * gl_NumWorkGroups.y - 1) return;
  memoryBarrierBuffer();
  uint ends[2] = uint[2](atomicAdd(counters.counters.listEnd[0], 0), atomicAdd(counters.counters.listEnd[1], 0));
  writePassOneArgs(ends, atomicAdd(counters.counters.candidates, 0));
}
