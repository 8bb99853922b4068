#version 460
// The forward renderer's colour target cleared to the background before the opaque pass (loaded,
// not cleared, by it): a compute store writes at memory speed where the render pass's clear runs
// at the fixed-function rate (forward_renderer.cpp, "Clears").
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "mirage/shaderio/forward.h"

layout(push_constant, scalar) uniform Push { ForwardClearPush push; };
layout(set = 0, binding = 0, rgba16f) uniform writeonly image2D colorImage;
layout(local_size_x = 8, local_size_y = 8) in;

void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (p.x < int(push.width) && p.y < int(push.height)) imageStore(colorImage, p, push.value);
}
