#version 460
// Weighted blended transparency, resolve: the opaque colour times the revealage (the product of
// 1 - alpha over the pixel's layers) plus the weighted average colour of the layers times their
// coverage 1 - revealage. Exact for one layer; with several, an order-independent approximation.
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "mirage/shaderio/forward.h"

layout(push_constant, scalar) uniform Push { ForwardResolvePush push; };
layout(set = 0, binding = 0, rgba16f) uniform image2D colorImage;
layout(set = 0, binding = 1, rgba16f) uniform readonly image2D accumImage;
layout(set = 0, binding = 2, rgba16f) uniform readonly image2D revealImage;
layout(local_size_x = 8, local_size_y = 8) in;

void main() {
  ivec2 p = ivec2(gl_GlobalInvocationID.xy);
  if (p.x >= int(push.width) || p.y >= int(push.height)) return;
  vec4 accum = imageLoad(accumImage, p); // sum of rgb a w, revealage
  float reveal = accum.a;
  if (reveal >= 1.0) return; // no blended layer (or only fully transparent ones)
  vec3 average = accum.rgb / clamp(imageLoad(revealImage, p).r, 1e-4, 5e4); // over the sum of a w
  vec3 color = imageLoad(colorImage, p).rgb;
  imageStore(colorImage, p, vec4(mix(average, color, reveal), 1.0));
}
