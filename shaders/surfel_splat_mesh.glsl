// Body of the mesh-shader disc splatters (surfel_splat.mesh; surfel_splat_depth.mesh defines
// MIRAGE_SPLAT_LAYERED): one quad per (disc, view), 32 per work group (surfel_splat_raster.glsl).
#include "surfel_splat_raster.glsl"

layout(local_size_x = 32) in;
layout(triangles, max_vertices = 128, max_primitives = 64) out;
layout(location = 0) flat out vec4 outDisc[];
layout(location = 1) flat out uvec2 outIds[];
#ifdef MIRAGE_SPLAT_LAYERED
// Redeclared with gl_Layer alone: the full block would declare the shading-rate capability too.
perprimitiveEXT out gl_MeshPerPrimitiveEXT { int gl_Layer; } gl_MeshPrimitivesEXT[];
#endif

void main() {
  uint pairs = push.count * SurfelGlobalsRef(push.globals).g.viewCount;
  uint base = gl_WorkGroupID.x * 32;
  uint n = min(32, pairs - base);
  SetMeshOutputsEXT(4 * n, 2 * n);
  uint i = gl_LocalInvocationIndex;
  if (i >= n) return;
  SplatQuad q = splatQuad(base + i);
  vec2 corner[4] = vec2[](q.corners.xy, q.corners.zy, q.corners.xw, q.corners.zw);
  for (uint k = 0; k < 4; ++k) {
    gl_MeshVerticesEXT[4 * i + k].gl_Position = vec4(corner[k], 0.0, 1.0);
    outDisc[4 * i + k] = q.disc;
    outIds[4 * i + k] = q.ids;
  }
  gl_PrimitiveTriangleIndicesEXT[2 * i] = uvec3(4 * i, 4 * i + 1, 4 * i + 2);
  gl_PrimitiveTriangleIndicesEXT[2 * i + 1] = uvec3(4 * i + 2, 4 * i + 1, 4 * i + 3);
#ifdef MIRAGE_SPLAT_LAYERED
  gl_MeshPrimitivesEXT[2 * i].gl_Layer = int(q.ids.y);
  gl_MeshPrimitivesEXT[2 * i + 1].gl_Layer = int(q.ids.y);
#endif
}
