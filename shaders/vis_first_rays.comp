#version 460
// After a claiming launch of the ray backend: the lowest ray of each triangle the launch inserted
// first, in the order of the new-ID list (RtGatherPush, shaderio/rays.h).
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "mirage/shaderio/rays.h"

layout(local_size_x = MIRAGE_RT_GATHER_GROUP) in;
layout(push_constant, scalar) uniform Push { RtGatherPush push; };

void main() {
  uint n = min(RtCountersRef(push.counters).c.newCount, push.newCapacity);
  RtU32Ref ids = RtU32Ref(push.newIds), first = RtU32Ref(push.firstRay), out_ = RtU32Ref(push.gathered);
  for (uint k = gl_GlobalInvocationID.x; k < n; k += MIRAGE_RT_GATHER_GROUP * MIRAGE_RT_GATHER_GROUPS)
    out_.v[k] = first.v[ids.v[k]];
}
