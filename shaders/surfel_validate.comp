#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
// Conflict resolution: a candidate survives when it still owns its own texel after every
// candidate's Poisson disc was splatted (no larger disc covers it). Losers and the padding up to
// push.padTo (the bitonic sort's power of two) become 0, which sorts last.
#include "mirage/shaderio/surfels.h"

layout(local_size_x = 256) in;
layout(push_constant, scalar) uniform Push { SurfelSamplerPush push; };

void main() {
  SurfelSamplerGlobals g = SurfelGlobalsRef(push.globals).g;
  for (uint i = gl_GlobalInvocationID.x; i < push.padTo; i += gl_NumWorkGroups.x * 256) {
    uint64_t k = i < push.count ? SurfelU64Ref(g.candidates).v[i] : uint64_t(0);
    if (k != 0 && SurfelU64Ref(g.owners).v[uint(k)] == k) {
      atomicAdd(SurfelCountersRef(g.counters).c.validCount, 1);
    } else {
      SurfelU64Ref(g.candidates).v[i] = 0;
    }
  }
}
