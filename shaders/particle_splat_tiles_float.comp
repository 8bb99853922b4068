#version 460
// The binned splat's tile pass (particle_splat_tiles.glsl), float accumulators.
#include "particle_splat_sums_float.glsl"
#include "particle_splat_tiles.glsl"
