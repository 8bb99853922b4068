#version 460
// Raster fallback: keep the pixels whose centre lies in the surfel's disc (or its ellipse) and the pixel holding its
// projection, as the compute splat does, and the surfels' share of the blend band; write (id, 0) with the depth test.
#include "surfel_render_common.glsl"

layout(location = 0) flat in uint inId;
layout(location = 1) flat in vec3 inDisc;
layout(location = 2) flat in float inFade;
layout(location = 3) flat in vec3 inShape;
layout(location = 0) out uvec2 outVis;

void main() {
  vec2 d = gl_FragCoord.xy - inDisc.xy;
  bool own = all(equal(floor(gl_FragCoord.xy), floor(inDisc.xy))); // the pixel holding the projection
  if (!own && !insideSurfelDisc(d, inDisc.z, inShape)) discard;
  if (inFade < 1.0 && fadeDither(uvec2(gl_FragCoord.xy)) >= inFade) discard;
  outVis = uvec2(inId, 0u);
}
