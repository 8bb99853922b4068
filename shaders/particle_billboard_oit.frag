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
  uint n = oitAllocate(l.counterAddress, l.nodeCapacity);
  if (n == kOitNoNode) return;
  OitColorRef(l.colorAddress).colors[n] = uvec2(packHalf2x16(c.rg), packHalf2x16(c.ba));
  uvec2 p = uvec2(gl_FragCoord.xy);
  oitLink(l.headAddress, l.nodeAddress, p.y * l.rowPixels + p.x, n, gl_FragCoord.z, n | l.idTag);
}
