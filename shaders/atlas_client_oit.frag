#version 460
// The thin client's BLEND patches: each fragment in front of the opaque depth (read-only, early
// tests) pushed onto its pixel's linked list, as the forward renderer's forward_oit.frag does; the
// forward resolve (forward_oit_resolve.comp) sorts and blends them over the opaque colour.
#include "atlas_client_common.glsl"
#include "oit_list.glsl"
#include "atlas_client_surface.glsl"

layout(early_fragment_tests) in;

layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer OitListsRef { OitLists lists; };
layout(buffer_reference, scalar, buffer_reference_align = 4) writeonly buffer OitColorRef { uvec2 colors[]; };

void main() {
  vec4 c = clientSurface();
  OitLists l = OitListsRef(push.oitAddress).lists;
  uvec2 p = uvec2(gl_FragCoord.xy);
  uint pixel = p.y * l.rowPixels + p.x;
  OitSlot s = oitAcquire(l.counterAddress, l.headAddress, l.nodeAddress, l.nodeCapacity, pixel, gl_FragCoord.z);
  if (s.node == kOitNoNode) return;
  OitColorRef(l.colorAddress).colors[s.node] = uvec2(packHalf2x16(c.rg), packHalf2x16(c.ba));
  oitCommit(l.headAddress, l.nodeAddress, pixel, s, gl_FragCoord.z, s.node + 1, /*payload=*/true);
}
