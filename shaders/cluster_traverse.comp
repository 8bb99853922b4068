#version 460
// Hierarchical selection (--selection hierarchy): breadth-first traversal of the per-level LOD
// BVHs (GpuLodNode, cluster.h), one indirect dispatch per depth, so no workgroup waits on another
// (lavapipe gives spinning persistent threads no forward-progress guarantee).
//   depth 0: one workgroup row per visible instance, one thread per level of its level range,
//            testing that level's root node;
//   depth d: one thread per node queued by depth d - 1 (uvec2(row, node) in queue d & 1).
// A node that passes the error bound and the frustum queues its children, or, as a leaf, runs the
// flat pass's per-cluster selection on its clusters. push.rasterList = phase | depth << 1.
#include "cluster_select.glsl"

layout(local_size_x = MIRAGE_CLUSTER_WORKGROUP) in;

layout(buffer_reference, scalar, buffer_reference_align = 4) buffer TraversalRef { ClusterTraversal traversal; };
layout(buffer_reference, scalar, buffer_reference_align = 8) buffer QueueRef { uvec2 items[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer NodeRef { GpuLodNode nodes[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer LeafClusterRef { uint clusters[]; };

// Queues `item` for the pass at `depth`; its dispatch grows by a workgroup every
// MIRAGE_CLUSTER_WORKGROUP items. Past the capacity the item is dropped and counted.
void queueNode(uint phase, uint depth, uvec2 item, ClusterFrame f) {
  TraversalRef t = TraversalRef(f.traversalAddress);
  uint slot = atomicAdd(t.traversal.args[phase][depth][3], 1);
  if (slot >= f.queueCapacity) {
    atomicAdd(t.traversal.queueOverflow, 1);
    atomicAdd(CounterRef(push.counterAddress).counters.clustersOverflow, 1);
    return;
  }
  if (slot % MIRAGE_CLUSTER_WORKGROUP == 0) atomicAdd(t.traversal.args[phase][depth][0], 1);
  if (slot == 0) {
    t.traversal.args[phase][depth][1] = 1;
    t.traversal.args[phase][depth][2] = 1;
  }
  QueueRef(f.queueAddress[depth & 1u]).items[slot] = item;
}

// Node `node` (mesh-relative) of visible instance `row`.
void visitNode(uint row, uint node, uint phase, uint depth, ClusterFrame f) {
  VisibleInstance vi = VisibleInstanceRef(push.visibleInstanceAddress).entries[row];
  GpuClusterInstance inst = InstanceRef(push.instanceAddress).instances[vi.instance];
  GpuClusterMesh mesh = MeshRef(push.meshAddress).meshes[inst.mesh];
  GpuLodNode n = NodeRef(f.nodeAddress).nodes[mesh.nodeOffset + node];
  atomicAdd(TraversalRef(f.traversalAddress).traversal.nodesTested, 1);
  // Every cluster beneath has projected parent error <= this bound (GpuLodNode); the 0.1% margin
  // keeps float rounding from skipping a node whose cluster the exact per-cluster test would take.
  // +inf (root beneath, or eye inside the sphere) always enters.
  if (!(projectedError(n.sphere, n.maxParentError, inst, f) * 1.001 > f.tau)) return;
  if ((f.flags & MIRAGE_FRAME_FRUSTUM_CULL) != 0 &&
      !sphereVisible(vec4((inst.model * vec4(n.sphere.xyz, 1.0)).xyz, n.sphere.w * inst.maxScale * 1.0001)))
    return;
  if (n.leaf != 0) {
    LeafClusterRef leaves = LeafClusterRef(f.leafClusterAddress);
    for (uint i = 0; i < n.childCount; ++i) selectCluster(vi.instance, inst, mesh, leaves.clusters[n.childOffset + i], phase);
    return;
  }
  for (uint i = 0; i < n.childCount; ++i) queueNode(phase, depth + 1, uvec2(row, n.childOffset + i), f);
}

void main() {
  uint phase = push.rasterList & 1u, depth = push.rasterList >> 1;
  ClusterFrame f = FrameRef(push.frameAddress).frame;
  if (depth == 0) {
    // Rows as in the flat pass: phase 0 the early instances, phase 1 the late ones that passed.
    CounterRef counters = CounterRef(push.counterAddress);
    uint first = phase == 0 ? 0 : counters.counters.earlyInstances;
    uint rows = phase == 0 ? counters.counters.earlyInstances : counters.counters.visibleInstances;
    for (uint row = first + gl_WorkGroupID.y; row < rows; row += gl_NumWorkGroups.y) {
      uint levels = VisibleInstanceRef(push.visibleInstanceAddress).entries[row].levels;
      for (uint l = gl_LocalInvocationID.x; l < (levels >> 16); l += MIRAGE_CLUSTER_WORKGROUP)
        visitNode(row, (levels & 0xffffu) + l, phase, 0, f);
    }
    return;
  }
  uint i = gl_GlobalInvocationID.x;
  uint queued = min(TraversalRef(f.traversalAddress).traversal.args[phase][depth][3], f.queueCapacity);
  if (i >= queued) return;
  uvec2 item = QueueRef(f.queueAddress[depth & 1u]).items[i];
  visitNode(item.x, item.y, phase, depth, f);
}
