#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
// Compute splatter of the progressive sampler (modes and the per-texel update:
// surfel_splat_common.glsl). Work group (tile, item, view): one 8×8-thread tile of the item's disc
// bounding square in one view.
#include "surfel_splat_common.glsl"

layout(local_size_x = 8, local_size_y = 8) in;

void main() {
  SurfelSamplerGlobals g = SurfelGlobalsRef(push.globals).g;
  SplatDisc d = splatDisc(g, push.first + gl_WorkGroupID.y);
  uint view = gl_WorkGroupID.z;
  ivec4 square = splatSquare(g, d, view);
  ivec2 tile = ivec2(gl_WorkGroupID.x % push.tilesPerSide, gl_WorkGroupID.x / push.tilesPerSide);
  ivec2 start = square.xy + tile * int(push.tileSpan);
  ivec2 end = min(start + ivec2(push.tileSpan) - 1, square.zw);
  uint res = g.resolution;
  uint base = view * res * res;
  for (int y = start.y + int(gl_LocalInvocationID.y); y <= end.y; y += 8)
    for (int x = start.x + int(gl_LocalInvocationID.x); x <= end.x; x += 8)
      splatTexel(g, d, base + uint(y) * res + uint(x));
}
