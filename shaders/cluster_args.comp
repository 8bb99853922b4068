#version 460
// Indirect arguments for every rasterizer from the visible-cluster count (one thread).
#include "cluster_common.glsl"

layout(local_size_x = 1) in;

void main() {
  uint n = visibleCount();
  CounterRef c = CounterRef(push.counterAddress);
  // One mesh / compute workgroup per visible cluster, split over x and y below the 65535 limit.
  c.counters.rasterArgs[0] = min(n, MIRAGE_CLUSTER_DISPATCH_X);
  c.counters.rasterArgs[1] = (n + MIRAGE_CLUSTER_DISPATCH_X - 1) / MIRAGE_CLUSTER_DISPATCH_X;
  c.counters.rasterArgs[2] = 1;
  // One instance per visible cluster, enough vertices for the largest cluster.
  c.counters.drawArgs[0] = 3 * MIRAGE_CLUSTER_MAX_TRIANGLES;
  c.counters.drawArgs[1] = n;
  c.counters.drawArgs[2] = 0;
  c.counters.drawArgs[3] = 0;
}
