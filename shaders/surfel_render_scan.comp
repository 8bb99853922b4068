#version 460
// One workgroup: exclusive prefix sums over the instances of their batch counts (where each
// instance's splat workgroups start) and surfel counts (their visibility ids; 0 stays background),
// in chunks of the workgroup size with a running carry, and each batch's instance; then the splat
// dispatch arguments. A single workgroup is enough for thousands of instances (a chunk per 256); a
// decoupled look-back scan would replace it for millions.
#include "surfel_render_common.glsl"

layout(local_size_x = MIRAGE_SURFEL_INSTANCE_WORKGROUP) in;

shared uvec2 sums[MIRAGE_SURFEL_INSTANCE_WORKGROUP];

void main() {
  uint n = SrFrameRef(push.frameAddress).frame.instanceCount;
  SrStateRef states = SrStateRef(push.stateAddress);
  uint t = gl_LocalInvocationIndex;
  uvec2 carry = uvec2(0u, 1u); // (batches, ids): id 0 is the background
  for (uint base = 0; base < n; base += MIRAGE_SURFEL_INSTANCE_WORKGROUP) {
    uint i = base + t;
    uvec2 own = i < n ? uvec2(states.states[i].batchCount, states.states[i].count) : uvec2(0u);
    sums[t] = own;
    barrier();
    // Hillis-Steele inclusive scan in shared memory.
    for (uint offset = 1u; offset < MIRAGE_SURFEL_INSTANCE_WORKGROUP; offset <<= 1) {
      uvec2 add = t >= offset ? sums[t - offset] : uvec2(0u);
      barrier();
      sums[t] += add;
      barrier();
    }
    if (i < n) {
      uvec2 first = carry + sums[t] - own;
      states.states[i].firstBatch = first.x;
      states.states[i].firstId = first.y;
      SrUintRef batchInstance = SrUintRef(push.batchInstanceAddress);
      for (uint b = 0; b < own.x; ++b) batchInstance.v[first.x + b] = i;
    }
    carry += sums[MIRAGE_SURFEL_INSTANCE_WORKGROUP - 1];
    barrier();
  }
  if (t == 0u) {
    SrCounterRef counters = SrCounterRef(push.counterAddress);
    uint batches = carry.x;
    counters.c.totalBatches = batches;
    counters.c.totalSurfels = carry.y - 1u;
    counters.c.splatArgs[0] = min(batches, uint(MIRAGE_SURFEL_DISPATCH_X));
    counters.c.splatArgs[1] = (batches + MIRAGE_SURFEL_DISPATCH_X - 1) / MIRAGE_SURFEL_DISPATCH_X;
    counters.c.splatArgs[2] = 1u;
  }
}
