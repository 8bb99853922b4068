#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
#extension GL_KHR_shader_subgroup_arithmetic : require
// Per Voronoi cell the farthest texel: cellMax[sample] = max((distance bits << 32) | texel), plus
// the largest distance of the round. Mode 1 (first round, no samples yet): every texel belongs to
// cell 0 with its distance to the capture centre, so cell 0's maximum is the deterministic first
// sample. Grid-stride over all texels.
#include "mirage/shaderio/surfels.h"

layout(local_size_x = 256) in;
layout(push_constant, scalar) uniform Push { SurfelSamplerPush push; };

void main() {
  SurfelSamplerGlobals g = SurfelGlobalsRef(push.globals).g;
  uint stride = gl_NumWorkGroups.x * 256;
  for (uint base = gl_WorkGroupID.x * 256; base < g.texelCount; base += stride) {
    uint t = base + gl_LocalInvocationID.x;
    uint bits = 0;
    if (t < g.texelCount) {
      vec4 q = SurfelVec4Ref(g.positions).v[t];
      if (q.w >= 0.5) {
        uint cell = 0;
        if (push.mode == 1) {
          bits = floatBitsToUint(distance(q.xyz, g.center.xyz));
        } else {
          uint64_t c = SurfelU64Ref(g.cells).v[t];
          cell = uint(c);
          bits = c == ~uint64_t(0) ? 0 : uint(c >> 32);
        }
        if (bits != 0) atomicMax(SurfelU64Ref(g.cellMax).v[cell], (uint64_t(bits) << 32) | uint64_t(t));
      }
    }
    // One atomic per subgroup for the round's maximum (contention on a single word otherwise).
    uint m = subgroupMax(bits);
    if (subgroupElect() && m != 0) atomicMax(SurfelCountersRef(g.counters).c.maxDistance, m);
  }
}
