#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
// Compute splatter of the progressive sampler. Work group (tile, item, view): one 8×8-thread tile of
// the item's disc bounding square in one view. Orthographic projection never lengthens distances,
// so every texel within 3D distance r of the item lies in the square of half-side r around its
// projection in every view. Two modes:
//  0 Voronoi: samples [first, first + count) with splat radius push.radius (<= 0: the whole view);
//    cells[t] = min((distance bits << 32) | sample): a discrete Voronoi diagram over all texels.
//  1 Poisson discs: candidates [first, first + count), each with its own radius (the key's high
//    word); owners[t] = max(key) over candidates whose disc covers t: the larger disc wins.
#include "mirage/shaderio/surfels.h"

layout(local_size_x = 8, local_size_y = 8) in;
layout(push_constant, scalar) uniform Push { SurfelSamplerPush push; };

void main() {
  SurfelSamplerGlobals g = SurfelGlobalsRef(push.globals).g;
  SurfelVec4Ref pos = SurfelVec4Ref(g.positions);
  uint item = push.first + gl_WorkGroupID.y;
  uint64_t key = 0;
  float r = push.radius;
  uint texel;
  if (push.mode == 0) {
    texel = SurfelU32Ref(g.samples).v[item];
  } else {
    key = SurfelU64Ref(g.candidates).v[item];
    texel = uint(key);
    r = uintBitsToFloat(uint(key >> 32));
  }
  vec3 p = pos.v[texel].xyz;
  uint view = gl_WorkGroupID.z;
  int res = int(g.resolution);
  bool whole = r <= 0.0;
  vec4 clip = SurfelViewRef(g.views).v[view].viewProj * vec4(p, 1.0);
  vec2 pixel = (clip.xy * 0.5 + 0.5) * float(res);
  float rp = r / g.texelSize + 1.0;
  ivec2 lo = whole ? ivec2(0) : max(ivec2(floor(pixel - rp)), ivec2(0));
  ivec2 hi = whole ? ivec2(res - 1) : min(ivec2(ceil(pixel + rp)), ivec2(res - 1));
  ivec2 tile = ivec2(gl_WorkGroupID.x % push.tilesPerSide, gl_WorkGroupID.x / push.tilesPerSide);
  ivec2 start = lo + tile * int(push.tileSpan);
  ivec2 end = min(start + ivec2(push.tileSpan) - 1, hi);
  uint base = view * uint(res) * uint(res);
  for (int y = start.y + int(gl_LocalInvocationID.y); y <= end.y; y += 8) {
    for (int x = start.x + int(gl_LocalInvocationID.x); x <= end.x; x += 8) {
      uint t = base + uint(y) * uint(res) + uint(x);
      vec4 q = pos.v[t];
      if (q.w < 0.5) continue;
      float d = distance(q.xyz, p);
      // The high word alone is read plainly (32-bit reads do not tear): distances only shrink and
      // owners only grow, so a stale value never skips an update that would win.
      if (push.mode == 0) {
        if (!whole && d >= r) continue;
        uint bits = floatBitsToUint(d);
        if (bits > SurfelU32Ref(g.cells).v[2 * t + 1]) continue;
        atomicMin(SurfelU64Ref(g.cells).v[t], (uint64_t(bits) << 32) | uint64_t(item));
      } else {
        if (d >= r) continue;
        if (uint(key >> 32) < SurfelU32Ref(g.owners).v[2 * t + 1]) continue;
        atomicMax(SurfelU64Ref(g.owners).v[t], key);
      }
    }
  }
}
