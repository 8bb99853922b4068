#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_shader_atomic_int64 : require
// Geometry-shader disc splatter: each point of the draw (surfel_splat.vert does nothing) is one
// (disc, view) and becomes a quad; surfel_splat.frag does the per-texel update.
#include "surfel_splat_raster.glsl"

layout(points) in;
layout(triangle_strip, max_vertices = 4) out;
layout(location = 0) flat out vec4 outDisc;
layout(location = 1) flat out uvec2 outIds;

void main() {
  SplatQuad q = splatQuad(uint(gl_PrimitiveIDIn));
  vec2 corner[4] = vec2[](q.corners.xy, q.corners.zy, q.corners.xw, q.corners.zw);
  for (uint k = 0; k < 4; ++k) {
    gl_Position = vec4(corner[k], 0.0, 1.0);
    outDisc = q.disc;
    outIds = q.ids;
    EmitVertex();
  }
  EndPrimitive();
}
