// LOD BVH traversal queues (hierarchical selection, cluster_traverse.comp): included by the cull
// and late-instance passes, which queue the level roots of the instances they keep, and by the
// traversal itself. Include after cluster_common.glsl.

layout(buffer_reference, scalar, buffer_reference_align = 4) buffer TraversalRef { ClusterTraversal traversal; };
layout(buffer_reference, scalar, buffer_reference_align = 8) buffer QueueRef { uvec2 items[]; };

// Queues `item` = (visible-instance row, mesh-relative node) for the traversal pass at `depth` of
// `phase`; that pass's dispatch grows by a workgroup every MIRAGE_CLUSTER_WORKGROUP items. Past
// the capacity the item is dropped and counted (its clusters then count as overflow).
void queueNode(uint phase, uint depth, uvec2 item) {
  FrameRef frame = FrameRef(push.frameAddress);
  TraversalRef t = TraversalRef(frame.frame.traversalAddress);
  uint slot = atomicAdd(t.traversal.args[phase][depth][3], 1);
  if (slot >= frame.frame.queueCapacity) {
    atomicAdd(t.traversal.queueOverflow, 1);
    atomicAdd(CounterRef(push.counterAddress).counters.clustersOverflow, 1);
    return;
  }
  if (slot % MIRAGE_CLUSTER_WORKGROUP == 0) atomicAdd(t.traversal.args[phase][depth][0], 1);
  if (slot == 0) {
    t.traversal.args[phase][depth][1] = 1;
    t.traversal.args[phase][depth][2] = 1;
  }
  QueueRef(frame.frame.queueAddress[depth & 1u]).items[slot] = item;
}

// The roots of the levels of visible instance `row` (VisibleInstance::levels), for depth 0.
// The DAG group tree (MIRAGE_FRAME_DAG) has one root whatever the level range.
void queueLevelRoots(uint phase, uint row, uint levels) {
  if ((FrameRef(push.frameAddress).frame.flags & MIRAGE_FRAME_DAG) != 0) {
    queueNode(phase, 0, uvec2(row, 0));
    return;
  }
  for (uint l = 0; l < (levels >> 16); ++l) queueNode(phase, 0, uvec2(row, (levels & 0xffffu) + l));
}
