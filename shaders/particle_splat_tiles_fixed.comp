#version 460
// The binned splat's tile pass (particle_splat_tiles.glsl), fixed accumulators.
#include "particle_splat_sums_fixed.glsl"
#include "particle_splat_tiles.glsl"
