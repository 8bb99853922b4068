#version 460
// Weighted blended transparency, accumulation (McGuire and Bavoil 2013, equation 7): every blended
// fragment adds its weighted premultiplied colour (target 0 rgb) and weighted alpha (target 1 r),
// colour channels blended ONE, ONE, and scales the revealage (both targets' alpha, ZERO,
// ONE_MINUS_SRC_ALPHA: *= 1 - a). One blend state for both targets: no independentBlend needed.
// The weight falls with view distance, so nearer layers dominate where the order matters;
// forward_weighted_resolve.comp normalizes.
#include "forward_common.glsl"
#include "forward_surface.glsl"
#include "oit_weighted.glsl"

layout(early_fragment_tests) in;

layout(location = 0) out vec4 outAccum;
layout(location = 1) out vec4 outReveal;

void main() {
  vec4 c = shadeForwardSurface();
  float z = 1.0 / gl_FragCoord.w; // view distance along the axis (perspective: w = -z_view)
  oitWeighted(c, z, outAccum, outReveal);
}
