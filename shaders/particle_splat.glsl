// The particle splat (docs/particles.md, "Splat"; src/render/particle_splat.cpp): one thread per
// record slot of every batch. A live particle whose billboard would be under push.belowPixels wide
// (eye 0; every eye sees the same view depth) is splatted: its square footprint (edge = that width,
// centred on the projected centre, rotation ignored) covers each pixel by the overlap area, and the
// pixel accumulates the particle's colour with alpha = particle alpha x overlap, weighted as the
// weighted blended transparency weights a fragment (oit_weighted.glsl), where the particle lies in
// front of the opaque depth. The colour is the sheet tile's average (its mip level of one texel per
// tile) through the billboards' colour rule. Coverage is conserved: the overlaps sum to the
// footprint's area, as the billboards' grown sub-pixel squares keep theirs. Larger particles are
// appended to the billboards' list. The includer defines splatAdd(index, value) (float or fixed
// point atomics).
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#extension GL_EXT_nonuniform_qualifier : require

#include "mirage/shaderio/particle_draw.h"
#include "mirage/shaderio/particles.h"
#include "mirage/shaderio/view.h"

layout(push_constant, scalar) uniform Push { ParticleSplatPush push; };
#include "particle_records.glsl"
#include "oit_weighted.glsl"

layout(set = 0, binding = 0) uniform sampler2D sheets[];
layout(set = 1, binding = 0) uniform sampler2D opaqueDepth; // D32, reverse-Z, the whole side-by-side target

layout(local_size_x = MIRAGE_PARTICLE_DRAW_GROUP) in;

void splatAdd(uint index, float value);

// The sheet tile's average texel: the level where the tile is one texel (the sheets are box-filtered
// mip chains of whole tiles), sampled at the tile's centre.
vec4 tileAverage(ParticleBatchInfo b, uint frame) {
  uvec2 tiles = uvec2(b.tilesX, b.tilesY);
  vec2 tile = particleTile(frame, tiles);
  vec2 texels = vec2(textureSize(sheets[nonuniformEXT(b.sheet)], 0)) / vec2(tiles);
  float level = log2(max(max(texels.x, texels.y), 1.0));
  return textureLod(sheets[nonuniformEXT(b.sheet)], (tile + 0.5) / vec2(tiles), level);
}

// One eye's footprint: each covered pixel in front of the opaque surface accumulates c (straight
// alpha) with its overlap as alpha share.
// (The camera's members are read one by one: a whole ViewFrame per thread would be 368 bytes.)
void splatEye(uint eye, vec3 position, float size, vec4 c) {
  ParticleViewRef view = ParticleViewRef(push.frameAddress[eye]);
  vec4 clip = view.camera.viewProj * vec4(position, 1.0);
  if (clip.w <= 0.0) return;
  vec3 ndc = clip.xyz / clip.w;
  if (ndc.z <= 0.0 || ndc.z > 1.0) return; // beyond the far plane or before the near one
  vec2 centre = (ndc.xy * 0.5 + 0.5) * vec2(push.eyeWidth, push.height);
  // The projection's w is the view distance -z (clip.w), as the billboard's centre.z.
  float half_ = 0.5 * particlePixels(view, size, -clip.w);
  vec2 lo = centre - half_, hi = centre + half_;
  ivec2 first = max(ivec2(floor(lo)), ivec2(0));
  ivec2 last = min(ivec2(ceil(hi)) - 1, ivec2(push.eyeWidth, push.height) - 1);
  uint row = push.eyes * push.eyeWidth;
  for (int y = first.y; y <= last.y; ++y) {
    float oy = min(hi.y, float(y + 1)) - max(lo.y, float(y));
    for (int x = first.x; x <= last.x; ++x) {
      float ox = min(hi.x, float(x + 1)) - max(lo.x, float(x));
      float a = c.a * ox * oy;
      if (!(a > 0.0)) continue;
      uint px = uint(x) + eye * push.eyeWidth;
      if (ndc.z <= texelFetch(opaqueDepth, ivec2(px, y), 0).r) continue; // behind (reverse-Z: GREATER passes)
      vec4 accum, reveal;
      oitWeighted(vec4(c.rgb, a), clip.w, accum, reveal); // the view distance, as 1 / gl_FragCoord.w
      uint base = (uint(y) * row + px) * MIRAGE_SPLAT_CHANNELS;
      splatAdd(base + 0u, accum.r);
      splatAdd(base + 1u, accum.g);
      splatAdd(base + 2u, accum.b);
      splatAdd(base + 3u, reveal.r);
      splatAdd(base + 4u, -log(1.0 - min(a, MIRAGE_SPLAT_MAX_ALPHA)));
    }
  }
}

void main() {
  uint g = (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * MIRAGE_PARTICLE_DRAW_GROUP +
           gl_LocalInvocationID.x;
  if (g >= push.total) return;
  ParticleSlot slot = particleSlot(push.batchAddress, push.batchCount, g);
  if (!particleLive(slot, push.argsAddress)) return;
  RenderParticle p = particleRecord(slot);
  ParticleViewRef view = ParticleViewRef(push.frameAddress[0]);
  float z = dot(vec4(view.camera.view[0][2], view.camera.view[1][2], view.camera.view[2][2], view.camera.view[3][2]),
                vec4(p.position, 1.0)); // the view-space z alone
  if (!(z < 0.0 && particlePixels(view, p.size, z) < push.belowPixels)) {
    // A billboard: large, or at or behind the eye plane (the billboard's clipping decides).
    uint n = atomicAdd(ParticleDrawArgsRef(push.largeArgsAddress).args[0].instanceCount, 1u);
    ParticleIndexRef(push.largeAddress).indices[n] = g;
    return;
  }
  vec4 c = particleShade(unpackUnorm4x8(p.color), tileAverage(slot.info, p.frame), slot.info.flags);
  if (!(c.a > 0.0)) return;
  for (uint e = 0; e < push.eyes; ++e) splatEye(e, p.position, p.size, c);
}
