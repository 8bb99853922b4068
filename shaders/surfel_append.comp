#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
// Append the sorted surviving candidates (a prefix of the key array) after sample push.first.
// The radius of a sample is its distance to the earlier samples: the key's high word, or
// push.radius for the very first sample (mode 1), which has no earlier samples.
#include "mirage/shaderio/surfels.h"

layout(local_size_x = 256) in;
layout(push_constant, scalar) uniform Push { SurfelSamplerPush push; };

void main() {
  SurfelSamplerGlobals g = SurfelGlobalsRef(push.globals).g;
  for (uint i = gl_GlobalInvocationID.x; i < push.count; i += gl_NumWorkGroups.x * 256) {
    uint64_t k = SurfelU64Ref(g.candidates).v[i];
    if (k == 0) continue;
    SurfelU32Ref(g.samples).v[push.first + i] = uint(k);
    SurfelF32Ref(g.radii).v[push.first + i] = push.mode == 1 ? push.radius : uintBitsToFloat(uint(k >> 32));
  }
}
