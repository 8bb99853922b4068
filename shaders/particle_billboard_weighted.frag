#version 460
// Particle billboards, weighted blended mode: the same accumulation as forward_weighted.frag.
#define MIRAGE_PARTICLE_FRAGMENT
#include "particle_billboard.glsl"
#include "oit_weighted.glsl"

layout(early_fragment_tests) in;
layout(location = 0) out vec4 outAccum;
layout(location = 1) out vec4 outReveal;

void main() {
  vec4 c = particleColor();
  oitWeighted(c, 1.0 / gl_FragCoord.w, outAccum, outReveal); // view distance along the axis
}
