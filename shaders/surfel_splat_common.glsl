// What every disc splatter of the progressive sampler shares (compute: surfel_splat.comp; raster:
// surfel_splat.mesh / surfel_splat.geom + surfel_splat.frag): the item's disc, its bounding square
// in one view and the per-texel test and atomic. Written once so every splatter visits a superset
// of the same texels and applies the same keys: the atomics' results, hence the whole sample order,
// are bit-identical whichever splatter runs. Two modes:
//  0 Voronoi: samples [first, first + count) with splat radius push.radius (<= 0: the whole view);
//    cells[t] = min((distance bits << 32) | sample): a discrete Voronoi diagram over all texels.
//  1 Poisson discs: candidates [first, first + count), each with its own radius (the key's high
//    word); owners[t] = max(key) over candidates whose disc covers t: the larger disc wins.
// Includers enable GL_EXT_buffer_reference, GL_EXT_scalar_block_layout,
// GL_EXT_shader_explicit_arithmetic_types_int64 and GL_EXT_shader_atomic_int64.
#include "mirage/shaderio/surfels.h"

layout(push_constant, scalar) uniform Push { SurfelSamplerPush push; };

struct SplatDisc {
  vec3 center;
  float radius; // <= 0 (Voronoi only): the whole view
  uint low;     // mode 0: the sample index; mode 1: the candidate's texel (its key's low word)
};

SplatDisc splatDisc(SurfelSamplerGlobals g, uint item) {
  SplatDisc d;
  d.radius = push.radius;
  uint texel;
  if (push.mode == 0) {
    texel = SurfelU32Ref(g.samples).v[item];
    d.low = item;
  } else {
    uint64_t key = SurfelU64Ref(g.candidates).v[item];
    texel = uint(key);
    d.low = texel;
    d.radius = uintBitsToFloat(uint(key >> 32));
  }
  d.center = SurfelVec4Ref(g.positions).v[texel].xyz;
  return d;
}

// Texel rectangle [lo, hi] (xy, zw) of the disc's bounding square in `view`: orthographic
// projection never lengthens distances, so every texel within 3D distance r of the centre lies in
// the square of half-side r (+1 texel) around its projection.
ivec4 splatSquare(SurfelSamplerGlobals g, SplatDisc d, uint view) {
  int res = int(g.resolution);
  if (d.radius <= 0.0) return ivec4(0, 0, res - 1, res - 1);
  vec4 clip = SurfelViewRef(g.views).v[view].viewProj * vec4(d.center, 1.0);
  vec2 pixel = (clip.xy * 0.5 + 0.5) * float(res);
  float rp = d.radius / g.texelSize + 1.0;
  return ivec4(max(ivec2(floor(pixel - rp)), ivec2(0)), min(ivec2(ceil(pixel + rp)), ivec2(res - 1)));
}

// Distance from the disc's centre to a texel's position. `precise`: no splatter may fuse it
// differently (an fma in one stage and not another would change which key wins).
float splatDistance(SplatDisc d, vec3 q) {
  vec3 e = q - d.center;
  precise float d2 = e.x * e.x + e.y * e.y + e.z * e.z;
  precise float dist = sqrt(d2);
  return dist;
}

// The disc's update of texel t (any texel of its square).
void splatTexel(SurfelSamplerGlobals g, SplatDisc d, uint t) {
  vec4 q = SurfelVec4Ref(g.positions).v[t];
  if (q.w < 0.5) return; // no surface seen at this texel
  float dist = splatDistance(d, q.xyz);
  // The high word alone is read plainly (32-bit reads do not tear): distances only shrink and
  // owners only grow, so a stale value never skips an update that would win.
  if (push.mode == 0) {
    if (d.radius > 0.0 && dist >= d.radius) return;
    uint bits = floatBitsToUint(dist);
    if (bits > SurfelU32Ref(g.cells).v[2 * t + 1]) return;
    atomicMin(SurfelU64Ref(g.cells).v[t], (uint64_t(bits) << 32) | uint64_t(d.low));
  } else {
    if (dist >= d.radius) return;
    uint high = floatBitsToUint(d.radius);
    if (high < SurfelU32Ref(g.owners).v[2 * t + 1]) return;
    atomicMax(SurfelU64Ref(g.owners).v[t], (uint64_t(high) << 32) | uint64_t(d.low));
  }
}
