#version 460
// Particle billboards, linked-list mode: each fragment in front of the opaque depth appended to
// its pixel's list exactly as forward_oit.frag appends the scene's blended fragments (or, in the
// cluster renderer, as its blend rasters do, the id tagged as a stored colour), so the resolve
// sorts particles and transparent geometry together. Invisible texels append nothing.
#define MIRAGE_PARTICLE_FRAGMENT
#include "particle_billboard.glsl"
#include "oit_list.glsl"

layout(early_fragment_tests) in;

layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer OitListsRef { OitLists lists; };
layout(buffer_reference, scalar, buffer_reference_align = 4) writeonly buffer OitColorRef { uvec2 colors[]; };

void main() {
  vec4 c = particleColor();
  if (c.a < 1.0 / 512.0) return; // below an 8-bit step: no layer
  OitLists l = OitListsRef(push.oitAddress).lists;
  uvec2 p = uvec2(gl_FragCoord.xy);
  uint pixel = p.y * l.rowPixels + p.x;
  OitSlot s = oitAcquire(l.counterAddress, l.headAddress, l.nodeAddress, l.nodeCapacity, pixel, gl_FragCoord.z);
  if (s.node == kOitNoNode) return;
  OitColorRef(l.colorAddress).colors[s.node] = uvec2(packHalf2x16(c.rg), packHalf2x16(c.ba));
  oitCommit(l.headAddress, l.nodeAddress, pixel, s, gl_FragCoord.z, (s.node + 1) | l.idTag, /*payload=*/true);
}
