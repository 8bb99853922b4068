#version 460
// Linked-list transparency, build (docs/render.md, "Transparency"): each blended fragment in front
// of the opaque depth (a read-only attachment tested before the shader: early tests, so occluded
// fragments append nothing) is shaded and pushed onto its pixel's list under the pool rule shared
// with the cluster renderer (oit_list.glsl). The node's id is its own index, naming its colour.
#include "forward_common.glsl"
#include "oit_list.glsl"
#include "forward_surface.glsl"

layout(early_fragment_tests) in;

layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer OitListsRef { OitLists lists; };
layout(buffer_reference, scalar, buffer_reference_align = 4) writeonly buffer OitColorRef { uvec2 colors[]; };

void main() {
  vec4 c = shadeForwardSurface();
  OitLists l = OitListsRef(push.oitAddress).lists;
  uint n = oitAllocate(l.counterAddress, l.nodeCapacity);
  if (n == kOitNoNode) return;
  OitColorRef(l.colorAddress).colors[n] = uvec2(packHalf2x16(c.rg), packHalf2x16(c.ba));
  uvec2 p = uvec2(gl_FragCoord.xy); // the target's pixel: in stereo the eye's half already
  oitLink(l.headAddress, l.nodeAddress, p.y * l.rowPixels + p.x, n, gl_FragCoord.z, n);
}
