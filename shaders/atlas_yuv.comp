#version 460
// The atlas as YUV 4:2:0 for the H.264 encoder (shaderio/atlas_shading.h, "AtlasYuvPush"): a thread
// takes MIRAGE_ATLAS_YUV_RUN texels of two rows, writes their luma (and, with stacked alpha, their
// alpha as the luma of the lower half) and the chroma of their four 2 x 2 quads, as whole words.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "mirage/shaderio/atlas_shading.h"

layout(local_size_x = MIRAGE_ATLAS_YUV_GROUP, local_size_y = MIRAGE_ATLAS_YUV_GROUP) in;
layout(set = 0, binding = 1, rgba8) uniform readonly image2D atlas;

layout(buffer_reference, scalar, buffer_reference_align = 4) writeonly buffer WordRef { uint words[]; };
layout(push_constant, scalar) uniform Push { AtlasYuvPush push; };

const float kKr = float(MIRAGE_BT709_KR), kKb = float(MIRAGE_BT709_KB), kKg = 1.0 - kKr - kKb;
const vec3 kLuma = vec3(kKr, kKg, kKb);

// A value in 0..255 rounded to the nearest byte (what swscale's fixed point rounds to, within 1).
uint toByte(float v) { return uint(clamp(floor(v + 0.5), 0.0, 255.0)); }

void main() {
  const uint side = push.side, run = MIRAGE_ATLAS_YUV_RUN;
  uvec2 id = gl_GlobalInvocationID.xy;
  if (id.x * run >= side || id.y * 2u >= side) return;
  const uint x0 = id.x * run, y0 = id.y * 2u;
  WordRef out_ = WordRef(push.outputAddress);

  vec3 quads[run / 2u];
  for (uint q = 0u; q < run / 2u; ++q) quads[q] = vec3(0.0);
  for (uint r = 0u; r < 2u; ++r) {
    uint luma[run / 4u], alpha[run / 4u];
    for (uint w = 0u; w < run / 4u; ++w) luma[w] = alpha[w] = 0u;
    for (uint k = 0u; k < run; ++k) {
      // The stored bytes (sRGB-encoded colour, linear alpha), exactly: unorm reads are byte / 255.
      vec4 bytes = floor(imageLoad(atlas, ivec2(x0 + k, y0 + r)) * 255.0 + 0.5);
      luma[k / 4u] |= toByte(dot(kLuma, bytes.rgb)) << (8u * (k % 4u));
      alpha[k / 4u] |= uint(bytes.a) << (8u * (k % 4u));
      quads[k / 2u] += bytes.rgb;
    }
    uint row = (y0 + r) * side + x0; // bytes
    for (uint w = 0u; w < run / 4u; ++w) {
      out_.words[row / 4u + w] = luma[w];
      if (push.stackedAlpha != 0u) out_.words[(row + side * side) / 4u + w] = alpha[w];
    }
  }

  uint u = 0u, v = 0u;
  for (uint q = 0u; q < run / 2u; ++q) {
    vec3 rgb = quads[q] * 0.25;
    float y = dot(kLuma, rgb);
    u |= toByte((rgb.b - y) / (2.0 * (1.0 - kKb)) + 128.0) << (8u * q);
    v |= toByte((rgb.r - y) / (2.0 * (1.0 - kKr)) + 128.0) << (8u * q);
  }
  uint chromaRow = id.y * (side / 2u) + x0 / 2u; // bytes into a chroma plane
  uint uPlane = atlasYuvUOffset(side, push.stackedAlpha), vPlane = atlasYuvVOffset(side, push.stackedAlpha);
  out_.words[(uPlane + chromaRow) / 4u] = u;
  out_.words[(vPlane + chromaRow) / 4u] = v;
  if (push.stackedAlpha != 0u) { // grey below: no chroma
    uint below = (side / 2u) * (side / 2u);
    out_.words[(uPlane + below + chromaRow) / 4u] = 0x80808080u;
    out_.words[(vPlane + below + chromaRow) / 4u] = 0x80808080u;
  }
}
