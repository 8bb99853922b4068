#version 460
// Per-instance culling, then the instance's level range: visible instances are appended with the
// range of their mesh's clusters that can be on the LOD cut, and counted into the selection
// dispatch (y: instances up to 65535, x: the widest range), so the cluster pass skips off-screen
// instances and levels far from the cut.
#extension GL_EXT_control_flow_attributes : require
#extension GL_KHR_shader_subgroup_ballot : require
#extension GL_KHR_shader_subgroup_arithmetic : require
#include "cluster_common.glsl"
#include "cluster_traversal.glsl"
#include "mirage/shaderio/lod_error.h"

layout(local_size_x = MIRAGE_CLUSTER_WORKGROUP) in;

#define MIRAGE_CULL_LEVEL_BATCH 8

void main() {
  uint i = gl_GlobalInvocationID.x;
  CounterRef counters = CounterRef(push.counterAddress);
  if (i == 0) {
    counters.counters.selectArgs[2] = 1;
    counters.counters.lateSelectArgs[2] = 1;
  }
  ClusterFrame f = FrameRef(push.frameAddress).frame;
  if (i >= f.instanceCount) return;
  GpuClusterInstance inst = InstanceRef(push.instanceAddress).instances[i];
  if ((f.flags & MIRAGE_FRAME_FRUSTUM_CULL) != 0 && !sphereVisible(inst.sphere)) return;
  if (instanceFade(i) >= 1.0) return; // mixed scenes: drawn by its surfels alone
  // Cell PVS: an instance with no cluster visible from the camera's cell skips selection.
  if ((f.flags & MIRAGE_FRAME_PVS) != 0 &&
      UintRef(f.pvsInstanceAddress).data[i] == MIRAGE_PVS_INSTANCE_CULLED) {
    atomicAdd(counters.counters.instancesPvsCulled, 1);
    return;
  }
  GpuClusterMesh mesh = MeshRef(push.meshAddress).meshes[inst.mesh];

  // Every LOD sphere of the mesh lies within `reach` of its centre, so its distance term
  // d = |c - eye| - r is within [dist - reach, dist + reach]. A level whose largest parent error,
  // projected at the nearest distance, is <= tau has every parent good enough (too fine); one whose
  // smallest self error, projected at the farthest, is > tau has no cluster good enough (too
  // coarse). Either way none of its clusters passes LOCALCUT. The 0.1% margins keep float rounding
  // in the per-cluster test from deciding otherwise.
  vec3 centre = (inst.model * vec4(mesh.sphere.xyz, 1.0)).xyz;
  float dist = length(centre - nearestEye(f, centre)); // 1-Lipschitz in the point, as |c - eye|
  float reach = mesh.reach * inst.maxScale;
  float dmin = dist - reach, dmax = dist + reach;
  uint first = 0, last = mesh.levelCount - 1;
  uint firstCluster = 0, endCluster = 0; // the range's clusters: first level's first, past the last level's
  if (dmin > 0.0) {
    float nearScale = inst.maxScale / max(dmin, f.camera.znear) * f.camera.pixelScale;
    float farScale = inst.maxScale / max(dmax, f.camera.znear) * f.camera.pixelScale;
    // Foveation: tau lies between f.tau and this bound over the mesh's spheres.
    float tauMax = f.tau;
    if ((f.flags & MIRAGE_FRAME_FOVEA) != 0)
      tauMax *= fovealTauScaleMax(centre, reach, f.camera.eye.xyz, f.fovea.xyz, f.fovea.w, f.foveaSlope);
    bool found = false;
    // The levels are loaded MIRAGE_CULL_LEVEL_BATCH at a time, all loads issued before any is
    // used: one memory latency per batch instead of one per level (the pass is a single wave of
    // dependent loads; H100, 2500 blobs: cull 0.012 -> 0.010-0.011 ms).
    for (uint base = 0; base < mesh.levelCount; base += MIRAGE_CULL_LEVEL_BATCH) {
      GpuClusterLevel batch[MIRAGE_CULL_LEVEL_BATCH];
      [[unroll]] for (uint k = 0; k < MIRAGE_CULL_LEVEL_BATCH; ++k)
        batch[k] = LevelRef(push.levelAddress).levels[mesh.levelOffset + min(base + k, mesh.levelCount - 1)];
      [[unroll]] for (uint k = 0; k < MIRAGE_CULL_LEVEL_BATCH; ++k) {
        uint l = base + k;
        GpuClusterLevel level = batch[k];
        bool tooFine = !isinf(level.maxParentError) && level.maxParentError * nearScale * 1.001 <= f.tau;
        // With residency a coarse cluster is drawn where its children's page is missing.
        bool tooCoarse = (f.flags & MIRAGE_FRAME_RESIDENCY) == 0 && level.minSelfError > 0.0 &&
                         level.minSelfError * farScale * 0.999 > tauMax;
        if (l >= mesh.levelCount || tooFine || tooCoarse) continue;
        if (!found) {
          first = l;
          firstCluster = level.firstCluster;
        }
        last = l;
        endCluster = level.firstCluster + level.clusterCount;
        found = true;
      }
    }
    if (!found) return; // nothing of this instance can be on the cut
  } else {
    GpuClusterLevel a = LevelRef(push.levelAddress).levels[mesh.levelOffset + first];
    GpuClusterLevel b = LevelRef(push.levelAddress).levels[mesh.levelOffset + last];
    firstCluster = a.firstCluster;
    endCluster = b.firstCluster + b.clusterCount;
  }
  uint count = endCluster - firstCluster;
  VisibleInstance entry = VisibleInstance(i, firstCluster, count, first | ((last - first + 1) << 16));
  uint groups = (count + MIRAGE_CLUSTER_WORKGROUP - 1) / MIRAGE_CLUSTER_WORKGROUP;
  // Occlusion: an instance that drew no pixel last frame waits for the HZB of pass 1
  // (cluster_instance_occlusion.comp) and, if it passes, the phase-2 selection.
  if ((f.flags & MIRAGE_FRAME_OCCLUSION) != 0 && !historyBitAt(f.instanceHistoryBase + i)) {
    uint late = atomicAdd(counters.counters.lateInstances, 1);
    if (late < MIRAGE_CLUSTER_DISPATCH_X) atomicAdd(counters.counters.lateSelectArgs[1], 1);
    atomicMax(counters.counters.lateSelectArgs[0], groups);
    VisibleInstanceRef(f.lateInstanceAddress).entries[late] = entry;
    return;
  }
  // One lane per subgroup appends for all of its lanes here (a slot each, in lane order) and
  // counts them: the counters share a cache line, and per-lane atomics on it serialize.
  uvec4 lanes = subgroupBallot(true);
  uint n = subgroupBallotBitCount(lanes), base = 0;
  uint widest = subgroupMax(groups);
  if (subgroupElect()) {
    base = atomicAdd(counters.counters.visibleInstances, n);
    atomicAdd(counters.counters.earlyInstances, n);
    // Selection workgroup rows: one per visible instance up to the dispatch limit; past it, each
    // row loops over several instances (cluster_select.comp).
    if (base < MIRAGE_CLUSTER_DISPATCH_X)
      atomicAdd(counters.counters.selectArgs[1], min(n, MIRAGE_CLUSTER_DISPATCH_X - base));
    atomicMax(counters.counters.selectArgs[0], widest);
  }
  uint slot = subgroupBroadcastFirst(base) + subgroupBallotExclusiveBitCount(lanes);
  VisibleInstanceRef(push.visibleInstanceAddress).entries[slot] = entry;
  // Hierarchical selection: the traversal starts at this instance's level roots.
  if ((f.flags & MIRAGE_FRAME_HIERARCHY) != 0) queueLevelRoots(0, slot, entry.levels);
}
