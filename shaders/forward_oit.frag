#version 460
// Linked-list transparency, build (docs/render.md, "Transparency"): each blended fragment in front
// of the opaque depth (a read-only attachment tested before the shader: early tests, so occluded
// fragments append nothing) is shaded and pushed onto its pixel's list under the pool rule shared
// with the cluster renderer (oit_list.glsl). The node's id is its own index + 1 (ids are never 0),
// naming its colour.
#include "forward_common.glsl"
#include "oit_list.glsl"
#include "forward_surface.glsl"

layout(early_fragment_tests) in;

layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer OitListsRef { OitLists lists; };
layout(buffer_reference, scalar, buffer_reference_align = 4) writeonly buffer OitColorRef { uvec2 colors[]; };

void main() {
  vec4 c = shadeForwardSurface();
  OitLists l = OitListsRef(push.oitAddress).lists;
  uvec2 p = uvec2(gl_FragCoord.xy); // the target's pixel: in stereo the eye's half already
  uint pixel = p.y * l.rowPixels + p.x;
  OitSlot s = oitAcquire(l.counterAddress, l.headAddress, l.nodeAddress, l.nodeCapacity, pixel, gl_FragCoord.z);
  if (s.node == kOitNoNode) return;
  OitColorRef(l.colorAddress).colors[s.node] = uvec2(packHalf2x16(c.rg), packHalf2x16(c.ba));
  oitCommit(l.headAddress, l.nodeAddress, pixel, s, gl_FragCoord.z, s.node + 1, /*payload=*/true);
}
