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
  uint n = oitAllocate(l.counterAddress, l.nodeCapacity);
  if (n == kOitNoNode) return;
  OitColorRef(l.colorAddress).colors[n] = uvec2(packHalf2x16(c.rg), packHalf2x16(c.ba));
  uvec2 p = uvec2(gl_FragCoord.xy);
  oitLink(l.headAddress, l.nodeAddress, p.y * l.rowPixels + p.x, n, gl_FragCoord.z, n);
}
