#version 460
// Indirect arguments of one raster pass (push.rasterList = pass) from the list ends (one thread):
// the pass draws what was appended since the previous pass. Pass 0 also sizes the occlusion pass
// over the candidates; pass 2 are the blend lists; MIRAGE_BLEND_QUEUE_ARGS the blend queue.
#include "cluster_common.glsl"

layout(local_size_x = 1) in;

// (x, y, 1) workgroups for n items of `perGroup`, x below the 65535 limit.
uvec3 splitDispatch(uint n, uint perGroup) {
  uint groups = (n + perGroup - 1) / perGroup;
  return uvec3(min(groups, MIRAGE_CLUSTER_DISPATCH_X), (groups + MIRAGE_CLUSTER_DISPATCH_X - 1) / MIRAGE_CLUSTER_DISPATCH_X, 1);
}

void main() {
  uint pass = push.rasterList;
  CounterRef c = CounterRef(push.counterAddress);
  if (pass == MIRAGE_BLEND_QUEUE_ARGS) { // after the compute blend raster: the blend queue's tiles
    uvec3 d = splitDispatch(uint(c.counters.blendQueueCounts), MIRAGE_BLEND_QUEUE_GROUP_TILES);
    c.counters.blendQueueArgs[0] = d.x;
    c.counters.blendQueueArgs[1] = d.y;
    c.counters.blendQueueArgs[2] = 1;
    return;
  }
  // Pass 2: the blend lists (compute, hardware), complete after both selection phases.
  for (uint list = 0; list < 2; ++list) {
    uint first = pass != 1 ? 0 : c.counters.lists[0][list].first + c.counters.lists[0][list].count;
    uint n = (pass == 2 ? c.counters.blendListEnd[list] : c.counters.listEnd[list]) - first;
    uvec3 d = splitDispatch(n, 1); // one mesh / compute workgroup per cluster
    c.counters.lists[pass][list].dispatch[0] = d.x;
    c.counters.lists[pass][list].dispatch[1] = d.y;
    c.counters.lists[pass][list].dispatch[2] = 1;
    c.counters.lists[pass][list].first = first;
    c.counters.lists[pass][list].count = n;
    // One instance per cluster, enough vertices for the largest cluster.
    c.counters.lists[pass][list].draw[0] = 3 * MIRAGE_CLUSTER_MAX_TRIANGLES;
    c.counters.lists[pass][list].draw[1] = n;
    c.counters.lists[pass][list].draw[2] = 0;
    c.counters.lists[pass][list].draw[3] = 0;
  }
  if (pass == 2) {
    c.counters.blendDepthDraw[0] = 3;
    c.counters.blendDepthDraw[1] = c.counters.lists[2][MIRAGE_LIST_DOWN].count > 0 ? 1 : 0;
    c.counters.blendDepthDraw[2] = 0;
    c.counters.blendDepthDraw[3] = 0;
  }
  if (pass == 0) {
    uint n = min(c.counters.candidates, FrameRef(push.frameAddress).frame.visibleCapacity);
    uvec3 o = splitDispatch(n, MIRAGE_CLUSTER_WORKGROUP);
    c.counters.occlusionArgs[0] = o.x;
    c.counters.occlusionArgs[1] = o.y;
    c.counters.occlusionArgs[2] = 1;
    // One thread per late instance (at most the instance count: one row of groups suffices).
    c.counters.instanceOcclusionArgs[0] = (c.counters.lateInstances + MIRAGE_CLUSTER_WORKGROUP - 1) / MIRAGE_CLUSTER_WORKGROUP;
    c.counters.instanceOcclusionArgs[1] = 1;
    c.counters.instanceOcclusionArgs[2] = 1;
  }
}
