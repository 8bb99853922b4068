#version 460
// The thin client's patches: vertex i is corner i % 3 of triangle (i / 3) % 3 of slot
// i / MIRAGE_CLIENT_SLOT_VERTICES, placed and textured by the shared atlas layout (shaderio/atlas.h).
// A slot's triangles beyond its count, empty slots and patches of alpha modes this draw does not
// rasterize collapse to one point outside the depth range: no fragments, no per-mode buffers.
#include "atlas_client_common.glsl"

layout(location = 0) out vec2 outUv;
layout(location = 1) flat out uint outFlags;
layout(location = 2) flat out uint outColor;

void main() {
  uint slot = uint(gl_VertexIndex) / MIRAGE_CLIENT_SLOT_VERTICES;
  uint k = uint(gl_VertexIndex) % MIRAGE_CLIENT_SLOT_VERTICES;
  uint t = k / 3u;
  GpuClientPatch p = PatchRef(push.patchAddress).patches[slot];
  outFlags = p.flags;
  outColor = p.color;
  uint mode = p.flags & MIRAGE_CLIENT_ALPHA_MASK;
  if (t >= p.triangleCount || (push.alphaModes & (1u << mode)) == 0u) {
    outUv = vec2(0.0);
    gl_Position = vec4(0.0, 0.0, -1.0, 1.0);
    return;
  }
  uint v = atlasTriangleVertex(t, k % 3u);
  // Texel centres of the block's corners: bilinear taps stay inside the block (no gutters).
  outUv = (vec2(p.blockX, p.blockY) + atlasCornerTexel(v, p.blockLog2)) / push.atlasSize;
  gl_Position = ViewRef(push.frameAddress).view.viewProj * vec4(p.positions[v], 1.0);
}
