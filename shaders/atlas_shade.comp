#version 460
// The shading stage: one workgroup per 8 x 8 tile of a patch's block, a thread per texel. Each
// texel is shaded as the patch triangle atlasTexelTriangle assigns it, at the point whose
// barycentrics w.r.t. the triangle's corner texels (atlasCornerTexel) are those of the texel
// centre; texels outside the triangle extrapolate it (shaderio/atlas.h).
#include "atlas_surface.glsl"

layout(local_size_x = MIRAGE_ATLAS_TILE, local_size_y = MIRAGE_ATLAS_TILE) in;
layout(set = 0, binding = 1, rgba8) uniform writeonly image2D atlas;

layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer PatchRef { GpuAtlasPatch patches[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer TileRef { AtlasTile tiles[]; };
layout(push_constant, scalar) uniform Push { AtlasShadePush push; };

void main() {
  uint tileIndex = gl_WorkGroupID.x + gl_WorkGroupID.y * gl_NumWorkGroups.x;
  if (tileIndex >= push.tileCount) return;
  AtlasTile tile = TileRef(push.tileAddress).tiles[tileIndex];
  GpuAtlasPatch p = PatchRef(push.patchAddress).patches[tile.patchIndex];
  uvec2 texel = uvec2(tile.tile & 0xffffu, tile.tile >> 16) * MIRAGE_ATLAS_TILE + gl_LocalInvocationID.xy;
  uint h = 1u << p.blockLog2;
  if (texel.x >= atlasBlockWidth(p.triangleCount, p.blockLog2) || texel.y >= h) return;

  uint t = atlasTexelTriangle(texel, p.triangleCount, p.blockLog2);
  uvec3 slots = uvec3(atlasTriangleVertex(t, 0u), atlasTriangleVertex(t, 1u), atlasTriangleVertex(t, 2u));
  vec2 t0 = atlasCornerTexel(slots.x, p.blockLog2);
  vec2 e1 = atlasCornerTexel(slots.y, p.blockLog2) - t0;
  vec2 e2 = atlasCornerTexel(slots.z, p.blockLog2) - t0;
  // Barycentrics of the texel centre and their change per texel step (constant over the triangle).
  float inv = 1.0 / (e1.x * e2.y - e1.y * e2.x);
  vec2 q = vec2(texel) + 0.5 - t0;
  float b1 = (q.x * e2.y - q.y * e2.x) * inv, b2 = (e1.x * q.y - e1.y * q.x) * inv;
  vec3 bary = vec3(1.0 - b1 - b2, b1, b2);
  vec3 dbdx = vec3(-(e2.y - e1.y), e2.y, -e1.y) * inv;
  vec3 dbdy = vec3(-(e1.x - e2.x), -e2.x, e1.x) * inv;

  uvec3 v = uvec3(p.vertices[slots.x], p.vertices[slots.y], p.vertices[slots.z]);
  vec4 c = shadeTrianglePoint(v, p.instance, p.material, bary, dbdx, dbdy, push.frameAddress, push.vertexAddress,
                              push.instanceAddress, push.materialAddress);
  imageStore(atlas, ivec2(uvec2(p.blockX, p.blockY) + texel), encodeAtlasColor(c));
}
