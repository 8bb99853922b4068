#version 460
// The thin client's streamed particles: the look's block (shaderio/atlas.h: its tile's mip chain)
// sampled at the tile point, trilinearly between the two levels its pixel's footprint on the tile
// picks (the footprint a mipmapped fetch of the sheet measures: a particle far smaller than the one
// its look's block was sized for reads the coarse levels instead of aliasing the fine one), bilinear
// in linear as the sRGB atlas decodes; or the look's colour; times the particle's colour. In front of
// the opaque depth (read-only, early tests) appended to the pixel's list with the BLEND patches
// (atlas_client_oit.glsl), as the renderers' particle billboards join the blended geometry's lists.
#include "atlas_client_common.glsl"
#include "atlas_client_oit.glsl"

layout(early_fragment_tests) in;
layout(set = 0, binding = 0) uniform sampler2D atlas;

layout(location = 0) in vec2 inUv;
layout(location = 1) flat in vec4 inColor;
layout(location = 2) flat in uvec2 inBlock;

vec4 lookLevel(vec2 block, uint blockLog2, uint level) {
  return texture(atlas, (block + atlasParticleLevelTexel(inUv, blockLog2, level)) / push.atlasSize);
}

void main() {
  vec4 t;
  if (inBlock.y == 0u) {
    t = decodeAtlasColor(inBlock.x);
  } else {
    uint blockLog2 = inBlock.y;
    vec2 block = vec2(inBlock.x & 0xffffu, inBlock.x >> 16);
    // Level 0's texels a pixel steps over (the branch is uniform over a primitive: flat inputs).
    vec2 texel = inUv * float(1u << blockLog2);
    float rho = max(length(dFdx(texel)), length(dFdy(texel)));
    float lod = clamp(log2(max(rho, 1e-8)), 0.0, float(blockLog2));
    uint fine = uint(lod);
    t = mix(lookLevel(block, blockLog2, fine), lookLevel(block, blockLog2, min(fine + 1u, blockLog2)),
            lod - float(fine));
  }
  vec4 c = inColor * t;
  if (c.a < 1.0 / 512.0) return; // below an 8-bit step: no layer (as the renderers' billboards)
  appendFragment(c);
}
