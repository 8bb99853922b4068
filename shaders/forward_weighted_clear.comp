#version 460
// The weighted blended targets set to "nothing covers" (sums 0, revealage 1) before the blend
// pass loads them: as forward_clear.comp, a compute store instead of the render pass's clear.
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "mirage/shaderio/forward.h"

layout(push_constant, scalar) uniform Push { ForwardClearPush push; };
layout(set = 0, binding = 1, rgba16f) uniform writeonly image2D accumImage;
layout(set = 0, binding = 2, rgba16f) uniform writeonly image2D revealImage;
layout(local_size_x = 8, local_size_y = 8) in;

void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (p.x >= int(push.width) || p.y >= int(push.height)) return;
  imageStore(accumImage, p, push.value);
  imageStore(revealImage, p, push.value);
}
