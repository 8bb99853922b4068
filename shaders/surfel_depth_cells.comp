#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
// --disc-raster mesh-depth: the depth and id images (copied to buffers) back into the Voronoi cells
// the farthest pass reads: cells[t] = (distance bits << 32) | sample, ~0 where no sample reached.
// The distance is the depth · 2^depthShift, exactly the value the fragment shader computed.
#include "mirage/shaderio/surfels.h"

layout(local_size_x = 256) in;
layout(push_constant, scalar) uniform Push { SurfelSamplerPush push; };

void main() {
  SurfelSamplerGlobals g = SurfelGlobalsRef(push.globals).g;
  uint stride = gl_NumWorkGroups.x * 256;
  for (uint t = gl_GlobalInvocationID.x; t < g.texelCount; t += stride) {
    uint id = SurfelU32Ref(g.idCopy).v[t];
    float dist = ldexp(SurfelF32Ref(g.depthCopy).v[t], int(push.depthShift));
    SurfelU64Ref(g.cells).v[t] = id == ~0u ? ~uint64_t(0) : (uint64_t(floatBitsToUint(dist)) << 32) | uint64_t(id);
  }
}
