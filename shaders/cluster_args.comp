#version 460
// Indirect arguments of one raster pass (push.rasterList = pass) from the list ends (one thread):
// the pass draws what was appended since the previous pass. Pass 0 also sizes the occlusion pass
// over the candidates (after the hierarchical selection; the flat one writes pass 0's itself);
// pass 2 are the blend lists; MIRAGE_BLEND_QUEUE_ARGS the blend queue.
#include "cluster_common.glsl"
#include "cluster_args.glsl"

layout(local_size_x = 1) in;

void main() {
  uint pass = push.rasterList;
  CounterRef c = CounterRef(push.counterAddress);
  if (pass == MIRAGE_BLEND_QUEUE_ARGS) { // after the compute blend raster: the blend queue's tiles
    // None in the second rasterization of a fixed-slot frame that redoes nothing (shaderio/oit.h):
    // its compute blend raster returned at once, and the queue still holds the first one's.
    uint state = c.counters.oit.fixedState;
    bool idle = (state & MIRAGE_OIT_FIXED_SECOND) != 0u && (state & MIRAGE_OIT_FIXED_OVER) == 0u;
    uvec3 d = splitDispatch(idle ? 0u : uint(c.counters.blendQueueCounts), MIRAGE_BLEND_QUEUE_GROUP_TILES);
    c.counters.blendQueueArgs[0] = d.x;
    c.counters.blendQueueArgs[1] = d.y;
    c.counters.blendQueueArgs[2] = 1;
    return;
  }
  if (pass == 0) {
    writePassOneArgs(c.counters.listEnd, c.counters.candidates);
    return;
  }
  // Pass 2: the blend lists (compute, hardware), complete after both selection phases.
  for (uint list = 0; list < 2; ++list) {
    uint first = pass == 2 ? 0 : c.counters.lists[0][list].first + c.counters.lists[0][list].count;
    writeListArgs(pass, list, first, pass == 2 ? c.counters.blendListEnd[list] : c.counters.listEnd[list]);
  }
  if (pass == 2) {
    c.counters.blendDepthDraw[0] = 3;
    c.counters.blendDepthDraw[1] = c.counters.lists[2][MIRAGE_LIST_DOWN].count > 0 ? 1 : 0;
    c.counters.blendDepthDraw[2] = 0;
    c.counters.blendDepthDraw[3] = 0;
  }
}
