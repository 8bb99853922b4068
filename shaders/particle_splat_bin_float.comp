#version 460
// The binned splat's count and scatter passes (particle_splat_bin.glsl), float accumulators.
#include "particle_splat_sums_float.glsl"
#include "particle_splat_bin.glsl"
