#version 460
// Linked-list transparency, resolve: one thread per pixel gathers its list's nearest layers sorted
// by depth (oit_list.glsl, the cluster composite's code) and blends their stored colours back to
// front over the opaque colour. MIRAGE_OIT_LAYERS may be predefined (default MIRAGE_OIT_MAX_LAYERS).
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "mirage/shaderio/forward.h"
#include "oit_list.glsl"

layout(push_constant, scalar) uniform Push { ForwardResolvePush push; };
layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer OitListsRef { OitLists lists; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer OitColorRef { uvec2 colors[]; };
layout(set = 0, binding = 0, rgba16f) uniform image2D colorImage;
layout(local_size_x = 8, local_size_y = 8) in;

void main() {
  uvec2 p = gl_GlobalInvocationID.xy;
  if (p.x >= push.width || p.y >= push.height) return;
  OitLists l = OitListsRef(push.oitAddress).lists;
  OitPixelHead head = OitHeadRef(l.headAddress).pixels[p.y * l.rowPixels + p.x];
  if (head.fragments == 0) return;
  OitPixel list = oitGather(l.nodeAddress, l.nodeCapacity, head);
  oitCountPixel(l.counterAddress, list, /*requests=*/false);
  OitColorRef colors = OitColorRef(l.colorAddress);
  vec3 color = imageLoad(colorImage, ivec2(p)).rgb;
  for (int i = 0; i < list.count; ++i) {
    uvec2 c = colors.colors[min(max(uint(oitKeys[i] & 0xffffffffUL), 1u) - 1, l.nodeCapacity - 1)]; // id: node + 1
    color = oitBlend(color, vec4(unpackHalf2x16(c.x), unpackHalf2x16(c.y)));
  }
  imageStore(colorImage, ivec2(p), vec4(color, 1.0));
}
