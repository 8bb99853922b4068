#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
// One bitonic merge step (sequence size sortK, distance sortJ) over count = 2^m keys, descending:
// larger radius first, ties by larger texel index, so the order does not depend on the order in
// which candidates were appended.
#include "mirage/shaderio/surfels.h"

layout(local_size_x = 256) in;
layout(push_constant, scalar) uniform Push { SurfelSamplerPush push; };

void main() {
  SurfelSamplerGlobals g = SurfelGlobalsRef(push.globals).g;
  SurfelU64Ref keys = SurfelU64Ref(g.candidates);
  for (uint i = gl_GlobalInvocationID.x; i < push.count; i += gl_NumWorkGroups.x * 256) {
    uint l = i ^ push.sortJ;
    if (l <= i) continue;
    uint64_t a = keys.v[i], b = keys.v[l];
    bool descending = (i & push.sortK) == 0;
    if (descending ? a < b : a > b) {
      keys.v[i] = b;
      keys.v[l] = a;
    }
  }
}
