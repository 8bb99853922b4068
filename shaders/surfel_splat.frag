#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
// The raster splatters' per-texel update: the same atomic on the same key as the compute splatter
// (surfel_splat_common.glsl), for the texel under this fragment in the quad's view.
#include "surfel_splat_common.glsl"

layout(location = 0) flat in vec4 inDisc;
layout(location = 1) flat in uvec2 inIds;

void main() {
  SurfelSamplerGlobals g = SurfelGlobalsRef(push.globals).g;
  SplatDisc d;
  d.center = inDisc.xyz;
  d.radius = inDisc.w;
  d.low = inIds.x;
  uvec2 xy = uvec2(gl_FragCoord.xy);
  splatTexel(g, d, (inIds.y * g.resolution + xy.y) * g.resolution + xy.x);
}
