#version 460
// Hierarchical selection (--selection hierarchy): breadth-first traversal of the per-level LOD
// BVHs (GpuLodNode, cluster.h), one indirect dispatch per depth, so no workgroup waits on another
// (lavapipe gives spinning persistent threads no forward-progress guarantee). --selection dag runs
// the same kernel over the DAG's group tree (MIRAGE_FRAME_DAG, GpuClusterMesh::dagNodeOffset).
//   depth 0: the level roots of the visible instances' level ranges, queued by the cull pass
//            (phase 0) or the late-instance HZB test (phase 1);
//   depth d: one thread per node queued by depth d - 1 (uvec2(row, node) in queue d & 1).
// A node that passes the error bound and the frustum queues its children, or, as a leaf, runs the
// flat pass's per-cluster selection on its clusters (selectCluster: with GPU residency the
// resident cut and the page feedback too, whose every draw and request needs a parent error above
// tau and a sphere the node holds, so the nodes skipped lose neither). push.rasterList = phase |
// depth << 1.
#include "cluster_select.glsl" // includes cluster_common.glsl
#include "cluster_traversal.glsl"

layout(local_size_x = MIRAGE_CLUSTER_WORKGROUP) in;

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer NodeRef { GpuLodNode nodes[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer LeafClusterRef { uint clusters[]; };

// Node `node` (mesh-relative) of visible instance `row`.
void visitNode(uint row, uint node, uint phase, uint depth) {
  ClusterFrame f = FrameRef(push.frameAddress).frame;
  VisibleInstance vi = VisibleInstanceRef(push.visibleInstanceAddress).entries[row];
  GpuClusterInstance inst = InstanceRef(push.instanceAddress).instances[vi.instance];
  GpuClusterMesh mesh = MeshRef(push.meshAddress).meshes[inst.mesh];
  uint base = (f.flags & MIRAGE_FRAME_DAG) != 0 ? mesh.dagNodeOffset : mesh.nodeOffset;
  GpuLodNode n = NodeRef(f.nodeAddress).nodes[base + node];
  atomicAdd(TraversalRef(f.traversalAddress).traversal.nodesTested, 1);
  // Every cluster beneath has projected parent error <= this bound (GpuLodNode); the 0.1% margin
  // keeps float rounding from skipping a node whose cluster the exact per-cluster test would take.
  // +inf (root beneath, or eye inside the sphere) always enters.
  // Foveation: the node's sphere holds the parent spheres beneath, so its tau is never larger.
  if (!(projectedError(n.sphere, n.maxParentError, inst, f) * 1.001 > tauAt(n.sphere, inst, f))) return;
  if ((f.flags & MIRAGE_FRAME_FRUSTUM_CULL) != 0 &&
      !sphereVisible(vec4((inst.model * vec4(n.sphere.xyz, 1.0)).xyz, n.sphere.w * inst.maxScale * 1.0001)))
    return;
  if (n.leaf != 0) {
    LeafClusterRef leaves = LeafClusterRef(f.leafClusterAddress);
    for (uint i = 0; i < n.childCount; ++i) selectCluster(vi.instance, inst, mesh, leaves.clusters[n.childOffset + i], phase);
    return;
  }
  for (uint i = 0; i < n.childCount; ++i) queueNode(phase, depth + 1, uvec2(row, n.childOffset + i));
}

void main() {
  uint phase = push.rasterList & 1u, depth = push.rasterList >> 1;
  uint i = gl_GlobalInvocationID.x;
  FrameRef frame = FrameRef(push.frameAddress);
  uint queued = min(TraversalRef(frame.frame.traversalAddress).traversal.args[phase][depth][3], frame.frame.queueCapacity);
  if (i >= queued) return;
  uvec2 item = QueueRef(frame.frame.queueAddress[depth & 1u]).items[i];
  visitNode(item.x, item.y, phase, depth);
}
