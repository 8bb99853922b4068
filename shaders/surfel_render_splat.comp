#version 460
// The compute splat (surfel_render_splat.glsl).
#include "surfel_render_splat.glsl"
