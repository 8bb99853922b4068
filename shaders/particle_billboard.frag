#version 460
// Particle billboards, sorted mode: blended "over" by the pipeline, each gap of the depth-sorted
// particles between the sorted blended triangles it falls between (particle_sort.cpp).
#define MIRAGE_PARTICLE_FRAGMENT
#include "particle_billboard.glsl"

layout(early_fragment_tests) in;
layout(location = 0) out vec4 outColor;

void main() { outColor = particleColor(); }
