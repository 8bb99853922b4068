#version 460
// The thin client's streamed particles: the look's block sampled at the tile point
// (atlasParticleTexel: inside the block, bilinear in linear as the sRGB atlas decodes), or the
// look's colour, times the particle's colour; in front of the opaque depth (read-only, early tests)
// appended to the pixel's list with the BLEND patches (atlas_client_oit.glsl), as the renderers'
// particle billboards join the blended geometry's lists.
#include "atlas_client_common.glsl"
#include "atlas_client_oit.glsl"

layout(early_fragment_tests) in;
layout(set = 0, binding = 0) uniform sampler2D atlas;

layout(location = 0) in vec2 inUv;
layout(location = 1) flat in vec4 inColor;
layout(location = 2) flat in uvec2 inBlock;

void main() {
  vec4 t;
  if (inBlock.y == 0u) {
    t = decodeAtlasColor(inBlock.x);
  } else {
    vec2 texel = vec2(inBlock.x & 0xffffu, inBlock.x >> 16) + atlasParticleTexel(inUv, inBlock.y);
    t = texture(atlas, texel / push.atlasSize);
  }
  vec4 c = inColor * t;
  if (c.a < 1.0 / 512.0) return; // below an 8-bit step: no layer (as the renderers' billboards)
  appendFragment(c);
}
