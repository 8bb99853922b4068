#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
// Candidate filtering: the farthest texel of each cell [0, count) becomes a candidate when its
// distance is at least threshold × the round's largest distance (PADrend keeps >= 0.75).
#include "mirage/shaderio/surfels.h"

layout(local_size_x = 256) in;
layout(push_constant, scalar) uniform Push { SurfelSamplerPush push; };

void main() {
  SurfelSamplerGlobals g = SurfelGlobalsRef(push.globals).g;
  float maxDistance = uintBitsToFloat(SurfelCountersRef(g.counters).c.maxDistance);
  for (uint s = gl_GlobalInvocationID.x; s < push.count; s += gl_NumWorkGroups.x * 256) {
    uint64_t k = SurfelU64Ref(g.cellMax).v[s];
    float d = uintBitsToFloat(uint(k >> 32));
    if (k == 0 || d <= 0.0 || d < push.threshold * maxDistance) continue;
    uint slot = atomicAdd(SurfelCountersRef(g.counters).c.candidateCount, 1);
    SurfelU64Ref(g.candidates).v[slot] = k;
  }
}
