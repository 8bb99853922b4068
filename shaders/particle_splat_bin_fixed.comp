#version 460
// The binned splat's count and scatter passes (particle_splat_bin.glsl), fixed accumulators.
#include "particle_splat_sums_fixed.glsl"
#include "particle_splat_bin.glsl"
