// The thin client's transparent fragments (BLEND patches, particles): each pushed onto its pixel's
// linked list through the OitLists at push.oitAddress, as the forward renderer's forward_oit.frag
// does; the forward resolve (forward_oit_resolve.comp) sorts and blends them over the opaque colour.
// atlas_client_common.glsl included.
#include "oit_list.glsl"

layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer OitListsRef { OitLists lists; };
layout(buffer_reference, scalar, buffer_reference_align = 4) writeonly buffer OitColorRef { uvec2 colors[]; };

void appendFragment(vec4 c) {
  OitLists l = OitListsRef(push.oitAddress).lists;
  uvec2 p = uvec2(gl_FragCoord.xy);
  uint pixel = p.y * l.rowPixels + p.x;
  OitSlot s = oitAcquire(l.counterAddress, l.headAddress, l.nodeAddress, l.nodeCapacity, pixel, gl_FragCoord.z);
  if (s.node == kOitNoNode) return;
  OitColorRef(l.colorAddress).colors[s.node] = uvec2(packHalf2x16(c.rg), packHalf2x16(c.ba));
  oitCommit(l.headAddress, l.nodeAddress, pixel, s, gl_FragCoord.z, s.node + 1, /*payload=*/true);
}
