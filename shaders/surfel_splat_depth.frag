#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
// Depth-test Voronoi (--disc-raster mesh-depth): depth = distance · 2^-depthShift (exact: a power of
// two), id = sample; the depth test LESS keeps the nearest sample per texel. Ties keep the earlier
// primitive (rasterization order: item order within a draw, earlier rounds before), i.e. the
// smaller sample index, as atomicMin on (distance bits << 32 | sample) does.
#include "surfel_splat_common.glsl"

layout(location = 0) flat in vec4 inDisc;
layout(location = 1) flat in uvec2 inIds;
layout(location = 0) out uint outId;

void main() {
  SurfelSamplerGlobals g = SurfelGlobalsRef(push.globals).g;
  SplatDisc d;
  d.center = inDisc.xyz;
  d.radius = inDisc.w;
  d.low = inIds.x;
  uvec2 xy = uvec2(gl_FragCoord.xy);
  vec4 q = SurfelVec4Ref(g.positions).v[(inIds.y * g.resolution + xy.y) * g.resolution + xy.x];
  if (q.w < 0.5) discard; // no surface seen at this texel
  float dist = splatDistance(d, q.xyz);
  if (d.radius > 0.0 && dist >= d.radius) discard;
  gl_FragDepth = ldexp(dist, -int(push.depthShift));
  outId = d.low;
}
