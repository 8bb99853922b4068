#version 460
// The particle splat's resolve (docs/particles.md, "Splat"), after the transparency composite: per
// pixel with splatted coverage, the weighted average colour over its total coverage 1 - revealage,
// over the composited colour: mix(sum(rgb a w) / sum(a w), colour, exp(-sum(-log(1 - a)))), the
// weighted blended resolve (forward_weighted_resolve.comp) on the splat's sums.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "mirage/shaderio/particle_draw.h"

layout(push_constant, scalar) uniform Push { ParticleSplatPush push; };
layout(buffer_reference, scalar, buffer_reference_align = 4) readonly buffer SplatFloatRef { float v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 8) readonly buffer SplatFixedRef { uint64_t v[]; };
layout(set = 1, binding = 1, rgba16f) uniform image2D colorImage;
layout(local_size_x = 8, local_size_y = 8) in;

float channel(uint index) {
  if (push.fixedPoint != 0u)
    return float(SplatFixedRef(push.accumAddress).v[index]) * exp2(-float(MIRAGE_SPLAT_FIXED_BITS));
  return SplatFloatRef(push.accumAddress).v[index];
}

void main() {
  uvec2 p = gl_GlobalInvocationID.xy;
  uint row = push.eyes * push.eyeWidth;
  if (p.x >= row || p.y >= push.height) return;
  uint base = (p.y * row + p.x) * MIRAGE_SPLAT_CHANNELS;
  float logReveal = channel(base + 4u);
  if (!(logReveal > 0.0)) return; // nothing splatted here
  vec3 weighted = vec3(channel(base), channel(base + 1u), channel(base + 2u));
  vec3 average = weighted / max(channel(base + 3u), 1e-30);
  vec3 color = imageLoad(colorImage, ivec2(p)).rgb;
  imageStore(colorImage, ivec2(p), vec4(mix(average, color, exp(-logReveal)), 1.0));
}
