#version 460
// The particle splat by global float atomic adds (particle_splat_atomic.glsl).
#include "particle_splat_sums_float.glsl"
#include "particle_splat_atomic.glsl"
