// The particle splat (docs/particles.md, "Splat"; src/render/particle_splat.cpp), what its passes
// share. A live particle whose billboard would be under push.belowPixels wide (eye 0; every eye
// sees the same view depth) is splatted: its square footprint (edge = that width, centred on the
// projected centre, rotation ignored) covers each pixel by the overlap area, and the pixel
// accumulates the particle's colour with alpha = particle alpha x overlap, weighted as the
// weighted blended transparency weights a fragment (oit_weighted.glsl), where the particle lies in
// front of the opaque depth. The colour is the sheet tile's average (its mip level of one texel per
// tile) through the billboards' colour rule. Coverage is conserved: the overlaps sum to the
// footprint's area, as the billboards' grown sub-pixel squares keep theirs. Larger particles are
// appended to the billboards' list. The passes: particle_splat_atomic.glsl (every pixel's sums by
// global atomics), or binned by screen tiles (particle_splat_bin.glsl, particle_splat_scan.comp,
// particle_splat_tiles.glsl). The sums file included first (particle_splat_sums_*.glsl) defines
// splatAdd and splatStore (and their fixed-point twins) on the accumulators (float or fixed point).
#ifndef MIRAGE_PARTICLE_SPLAT_GLSL
#define MIRAGE_PARTICLE_SPLAT_GLSL
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

void splatAdd(uint index, float value);   // accumulator `index` += value (atomic)
void splatStore(uint index, float value); // accumulator `index` = value (its only writer)
// The same for a sum in units of 2^-MIRAGE_SPLAT_FIXED_BITS (splatUnits).
void splatAddUnits(uint index, uint64_t units);
void splatStoreUnits(uint index, uint64_t units);

// A sum's value in fixed point: units of 2^-MIRAGE_SPLAT_FIXED_BITS (the fixed accumulators, the
// binned splat's shared sums), rounded.
uint64_t splatUnits(float value) { return uint64_t(value * exp2(float(MIRAGE_SPLAT_FIXED_BITS)) + 0.5); }

// The sheet tile's average texel: the level where the tile is one texel (the sheets are box-filtered
// mip chains of whole tiles), sampled at the tile's centre.
vec4 tileAverage(ParticleBatchInfo b, uint frame) {
  uvec2 tiles = uvec2(b.tilesX, b.tilesY);
  vec2 tile = particleTile(frame, tiles);
  vec2 texels = vec2(textureSize(sheets[nonuniformEXT(b.sheet)], 0)) / vec2(tiles);
  float level = log2(max(max(texels.x, texels.y), 1.0));
  return textureLod(sheets[nonuniformEXT(b.sheet)], (tile + 0.5) / vec2(tiles), level);
}

// A splat's colour as a tile list's entry stores it (splatPack): 10 bits a colour channel, 16
// alpha. Every path sums the colour rounded so.
vec4 splatRoundColor(vec4 c) {
  c = clamp(c, 0.0, 1.0);
  return vec4(round(c.rgb * 1023.0) / 1023.0, round(c.a * 65535.0) / 65535.0);
}

// Global record g as the splat sees it: nothing (an empty slot), a billboard (appended to the
// billboards' list when `list`), or a splat of position, size and, with `shade`, colour c
// (straight alpha, rounded as a tile list's entry keeps it). The class does not depend on the
// colour (a splat of alpha 0 adds nothing), so that the binned count needs no sheet lookup.
#define SPLAT_NONE 0u
#define SPLAT_BILLBOARD 1u
#define SPLAT_SPLAT 2u
uint splatClassify(uint g, bool list, bool shade, out vec3 position, out float size, out vec4 c) {
  position = vec3(0.0), size = 0.0, c = vec4(0.0);
  if (g >= push.total) return SPLAT_NONE;
  ParticleSlot slot = particleSlot(push.batchAddress, push.batchCount, g);
  if (!particleLive(slot, push.argsAddress)) return SPLAT_NONE;
  RenderParticle p = particleRecord(slot);
  ParticleViewRef view = ParticleViewRef(push.frameAddress[0]);
  float z = dot(vec4(view.camera.view[0][2], view.camera.view[1][2], view.camera.view[2][2], view.camera.view[3][2]),
                vec4(p.position, 1.0)); // the view-space z alone
  if (!(z < 0.0 && particlePixels(view, p.size, z) < push.belowPixels)) {
    // A billboard: large, or at or behind the eye plane (the billboard's clipping decides).
    if (list) {
      uint n = atomicAdd(ParticleDrawArgsRef(push.largeArgsAddress).args[0].instanceCount, 1u);
      ParticleIndexRef(push.largeAddress).indices[n] = g;
    }
    return SPLAT_BILLBOARD;
  }
  if (shade)
    c = splatRoundColor(particleShade(unpackUnorm4x8(p.color), tileAverage(slot.info, p.frame), slot.info.flags));
  position = p.position, size = p.size;
  return SPLAT_SPLAT;
}

// A splat as one eye sees it: its footprint lo..hi in the eye's pixels, its NDC depth, the weight
// factor of its view distance, and the pixels it may touch (first..last, inside the eye). Corner
// and edge lie on the grid of MIRAGE_SPLAT_SUBPIXELS, as a tile list's entry stores them
// (splatPack), so that every path sums the same footprint.
struct SplatFootprint {
  vec2 lo, hi;
  float depth, weight;
  ivec2 first, last;
};
// The weight factor at NDC depth `depth` of the eye: its view distance w solved from
// depth = (P22 z + P32) / (P23 z + P33), w = P23 z + P33 (perspective: -z; orthographic: 1). A tile
// list's entry keeps the depth alone.
float splatWeight(ParticleViewRef view, float depth) {
  float p22 = view.camera.proj[2][2], p32 = view.camera.proj[3][2];
  float p23 = view.camera.proj[2][3], p33 = view.camera.proj[3][3];
  float z = (p32 - depth * p33) / (depth * p23 - p22);
  return oitWeightedFactor(p23 * z + p33); // the view distance, as 1 / gl_FragCoord.w
}
// The pixels footprint lo..hi may touch, inside the eye.
void splatPixels(inout SplatFootprint f) {
  f.first = max(ivec2(floor(f.lo)), ivec2(0));
  f.last = min(ivec2(ceil(f.hi)) - 1, ivec2(push.eyeWidth, push.height) - 1);
}
// False where the eye does not see it (behind the eye, before the near or beyond the far plane).
// (The camera's members are read one by one: a whole ViewFrame per thread would be 368 bytes.)
bool splatFootprint(uint eye, vec3 position, float size, out SplatFootprint f) {
  ParticleViewRef view = ParticleViewRef(push.frameAddress[eye]);
  vec4 clip = view.camera.viewProj * vec4(position, 1.0);
  f.lo = f.hi = vec2(0.0), f.depth = f.weight = 0.0, f.first = ivec2(0), f.last = ivec2(-1);
  if (clip.w <= 0.0) return false;
  vec3 ndc = clip.xyz / clip.w;
  if (ndc.z <= 0.0 || ndc.z > 1.0) return false; // beyond the far plane or before the near one
  vec2 centre = (ndc.xy * 0.5 + 0.5) * vec2(push.eyeWidth, push.height);
  // The projection's w is the view distance -z (clip.w), as the billboard's centre.z.
  float edge = particlePixels(view, size, -clip.w);
  vec2 corner = round((centre - 0.5 * edge) * MIRAGE_SPLAT_SUBPIXELS); // whole units of the grid
  float edgeUnits = round(edge * MIRAGE_SPLAT_SUBPIXELS);
  f.lo = corner / MIRAGE_SPLAT_SUBPIXELS, f.hi = (corner + edgeUnits) / MIRAGE_SPLAT_SUBPIXELS;
  f.depth = ndc.z;
  f.weight = splatWeight(view, f.depth);
  splatPixels(f);
  return true;
}

// Footprint f with colour c (rounded: splatRoundColor) as the list of the tile at `origin` (eye
// pixels) holds it: MIRAGE_SPLAT_ENTRY_BYTES (shaderio/particle_draw.h).
uvec4 splatPack(SplatFootprint f, vec4 c, ivec2 origin) {
  ivec2 corner = ivec2(f.lo * MIRAGE_SPLAT_SUBPIXELS) - origin * int(MIRAGE_SPLAT_SUBPIXELS) + 32768;
  uint edge = uint(round((f.hi.x - f.lo.x) * MIRAGE_SPLAT_SUBPIXELS));
  uvec3 rgb = uvec3(round(c.rgb * 1023.0));
  return uvec4(uint(corner.x) | (uint(corner.y) << 16u), edge | (uint(round(c.a * 65535.0)) << 16u), floatBitsToUint(f.depth),
               rgb.r | (rgb.g << 10u) | (rgb.b << 20u));
}
// The footprint (its pixels inside the eye) and colour of entry e of the list of the tile at
// `origin` of eye `eye`: those splatPack took.
void splatUnpack(uvec4 e, uint eye, ivec2 origin, out SplatFootprint f, out vec4 c) {
  vec2 corner = vec2(ivec2(e.x & 0xffffu, e.x >> 16u) - 32768 + origin * int(MIRAGE_SPLAT_SUBPIXELS));
  float edgeUnits = float(e.y & 0xffffu);
  f.lo = corner / MIRAGE_SPLAT_SUBPIXELS, f.hi = (corner + edgeUnits) / MIRAGE_SPLAT_SUBPIXELS;
  f.depth = uintBitsToFloat(e.z);
  f.weight = splatWeight(ParticleViewRef(push.frameAddress[eye]), f.depth);
  splatPixels(f);
  c = vec4(vec3(e.w & 1023u, (e.w >> 10u) & 1023u, e.w >> 20u) / 1023.0, float(e.y >> 16u) / 65535.0);
}

// Alpha of pixel (x, y) (eye pixels) under footprint lo..hi of a colour of alpha `alpha`: its
// share of the pixel's area.
float splatCoverage(vec2 lo, vec2 hi, float alpha, int x, int y) {
  float oy = min(hi.y, float(y + 1)) - max(lo.y, float(y));
  float ox = min(hi.x, float(x + 1)) - max(lo.x, float(x));
  return alpha * ox * oy;
}
// The five sums a pixel takes from colour rgb at alpha a (> 0) and weight factor `weight`:
// weighted premultiplied colour (xyz), weighted alpha (w), as oitWeighted; and -log(1 - a).
vec4 splatSums(vec3 rgb, float a, float weight, out float logReveal) {
  float w = a * weight;
  logReveal = -log(1.0 - min(a, MIRAGE_SPLAT_MAX_ALPHA));
  return vec4(rgb * (a * w), a * w);
}
// The accumulators' first index of target pixel (px, y) (px over both eyes).
uint splatBase(uint px, uint y) { return (y * push.eyes * push.eyeWidth + px) * MIRAGE_SPLAT_CHANNELS; }

// Footprint f of eye `eye` added to the accumulators by global atomics, over the pixels of
// first..last (inside the footprint's own) in front of the opaque depth.
void splatDirect(uint eye, SplatFootprint f, vec4 c, ivec2 first, ivec2 last) {
  for (int y = first.y; y <= last.y; ++y)
    for (int x = first.x; x <= last.x; ++x) {
      float a = splatCoverage(f.lo, f.hi, c.a, x, y);
      if (!(a > 0.0)) continue;
      uint px = uint(x) + eye * push.eyeWidth;
      if (f.depth <= texelFetch(opaqueDepth, ivec2(px, y), 0).r) continue; // behind (reverse-Z: GREATER passes)
      float logReveal;
      vec4 sums = splatSums(c.rgb, a, f.weight, logReveal);
      uint base = splatBase(px, uint(y));
      splatAdd(base + 0u, sums.x);
      splatAdd(base + 1u, sums.y);
      splatAdd(base + 2u, sums.z);
      splatAdd(base + 3u, sums.w);
      splatAdd(base + 4u, logReveal);
    }
}

// The invocation's record over a dispatch of rows of workgroups (cmdDispatchRecords).
uint splatRecordIndex() {
  return (gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x) * MIRAGE_PARTICLE_DRAW_GROUP +
         gl_LocalInvocationID.x;
}
#endif
