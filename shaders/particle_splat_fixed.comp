#version 460
// The particle splat by global 64-bit fixed-point atomic adds (particle_splat_atomic.glsl).
#include "particle_splat_sums_fixed.glsl"
#include "particle_splat_atomic.glsl"
