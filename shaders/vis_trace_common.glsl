// Shared by both traversals of the ray backend, the ray-tracing pipeline (vis_trace.rgen and its
// hit shaders) and the compute traversal (vis_trace.comp): push constants, the per-ray result
// (Payload), the ray sources (buffer, generated, cell) and what happens after the closest hit is
// known (record/require sets, see-through candidates, first-ray claims). Stage-neutral: no
// ray-tracing extension here.
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
#include "mirage/shaderio/gvs_explore.h"

layout(push_constant, scalar) uniform Push { RtTracePush push; };

struct Payload {
  uint triangle; // closest opaque hit (global ID) or MIRAGE_RT_NO_HIT
  float t;
  uint count; // see-through candidates below
  uint ids[MIRAGE_RT_MAX_CANDIDATES];
  float ts[MIRAGE_RT_MAX_CANDIDATES];
};

// The bit sets use 32-bit words: the same bytes as TriangleSet's 64-bit words (little endian).
bool testBit(uint64_t set, uint id) { return ((RtU32Ref(set).v[id >> 5] >> (id & 31u)) & 1u) != 0u; }

// A see-through hit at `t` is remembered and ignored, as Embree's intersection filter does; `tmax`
// is the closest opaque hit so far. When the list is full, candidates behind `tmax` are dropped
// (they can never count). A triangle met twice (the compute BVH's spatial splits put one triangle
// in several leaves) is kept once.
void addSeeThrough(inout Payload p, uint id, float t, float tmax) {
  for (uint c = 0u; c < p.count; ++c)
    if (p.ids[c] == id) return;
  if (p.count == MIRAGE_RT_MAX_CANDIDATES) {
    uint kept = 0u;
    for (uint c = 0u; c < p.count; ++c) {
      if (p.ts[c] < tmax) {
        p.ids[kept] = p.ids[c];
        p.ts[kept] = p.ts[c];
        ++kept;
      }
    }
    p.count = kept;
  }
  if (p.count < MIRAGE_RT_MAX_CANDIDATES) {
    p.ids[p.count] = id;
    p.ts[p.count] = t;
    ++p.count;
  }
}

#ifndef MIRAGE_RT_HIT_STAGE
// PCG hash (Jarzynski & Olano 2020): decorrelated random numbers from (seed, index) alone.
uint pcg(uint v) {
  uint state = v * 747796405u + 2891336453u;
  uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
  return (word >> 22u) ^ word;
}
float unit(uint v) { return float(v >> 8) * (1.0 / 16777216.0); }

RtRay generatedRay(uint index) {
  uint h = pcg(index ^ pcg(push.seed));
  uint h1 = pcg(h), h2 = pcg(h1), h3 = pcg(h2), h4 = pcg(h3);
  RtRay r;
  r.origin = mix(push.boxMin, push.boxMax, vec3(unit(h), unit(h1), unit(h2)));
  float z = 1.0 - 2.0 * unit(h3);
  float s = sqrt(max(0.0, 1.0 - z * z));
  float phi = 6.28318530718 * unit(h4);
  r.dir = vec3(s * cos(phi), s * sin(phi), z);
  r.tnear = 0.0;
  r.tfar = 1.0 / 0.0;
  return r;
}

// Radical inverse of `index` in `base` (float digits: enough for sample positions). Launch indices
// below 2^32 take the 32-bit path; 64-bit division is emulated and far slower.
float radicalInverse(uint64_t index, uint base) {
  float inv = 1.0 / float(base), f = inv, r = 0.0;
  if (index <= 0xffffffffUL) {
    uint i = uint(index);
    if (base == 2u) return float(bitfieldReverse(i)) * (1.0 / 4294967296.0);
    while (i > 0u) {
      r += float(i % base) * f;
      i /= base;
      f *= inv;
    }
    return r;
  }
  while (index > 0UL) {
    r += float(uint(index % uint64_t(base))) * f;
    index /= uint64_t(base);
    f *= inv;
  }
  return r;
}

float wrapUnit(float v) { return v >= 1.0 ? v - 1.0 : v; }

// A point on the cell's surface: `select` picks the face by area, (u, v) the point on it
// (SurfaceSampler::point in sampling.h).
vec3 cellSurfacePoint(float select, float u, float v) {
  RtCellSourceRef src = RtCellSourceRef(push.cell);
  uint face = 0u;
  while (face + 1u < src.s.faceCount && select >= src.s.faces[face].cdf) ++face;
  return src.s.faces[face].corner + src.s.faces[face].edgeU * u + src.s.faces[face].edgeV * v;
}

// GVS++ random ray `index` of a cell: the same map as the host sampler (sampling.h).
RtRay cellRay(uint index) {
  RtCellSourceRef src = RtCellSourceRef(push.cell);
  uint64_t h = src.s.firstIndex + uint64_t(index) + 1UL;
  float select = wrapUnit(radicalInverse(h, 2u) + src.s.offset0);
  float u = wrapUnit(radicalInverse(h, 3u) + src.s.offset1);
  float v = wrapUnit(radicalInverse(h, 5u) + src.s.offset2);
  float du = wrapUnit(radicalInverse(h, 7u) + src.s.offset3);
  float dv = wrapUnit(radicalInverse(h, 11u) + src.s.offset4);
  RtRay r;
  r.origin = cellSurfacePoint(select, u, v);
  float z = 1.0 - 2.0 * du;
  float s = sqrt(max(0.0, 1.0 - z * z));
  float phi = 6.28318530718 * dv;
  r.dir = vec3(s * cos(phi), s * sin(phi), z);
  r.tnear = 0.0;
  r.tfar = 1.0 / 0.0;
  return r;
}

// A triangle absent from the set as the launch began: the lowest ray index that saw it wins.
void claim(uint id, uint index) {
  RtCellSourceRef src = RtCellSourceRef(push.cell);
  if (testBit(src.s.before, id)) return;
  atomicMin(RtU32Ref(src.s.firstRay).v[id], index);
}

// Degenerate rays (NaN, coordinates beyond kMaxRayCoordinate = 1e18, a zero direction, an
// inverted interval) are misses: validRay in ray_backend.h, the one contract for every backend.
bool validRay(RtRay r) {
  return !any(isnan(r.origin)) && !any(isnan(r.dir)) && all(lessThanEqual(abs(r.origin), vec3(1e18))) &&
         all(lessThanEqual(abs(r.dir), vec3(1e18))) &&
         dot(r.dir, r.dir) > 0.0 && r.tnear >= 0.0 && r.tnear <= r.tfar;
}

// True when this call set the bit first; then the ID is appended for the host.
bool insert(uint id) {
  if (testBit(push.record, id)) return false; // most hits land on known triangles: read first
  uint bit = 1u << (id & 31u);
  if ((atomicOr(RtU32Ref(push.record).v[id >> 5], bit) & bit) != 0u) return false;
  uint slot = atomicAdd(RtCountersRef(push.counters).c.newCount, 1u);
  if (slot < push.newCapacity) RtU32Ref(push.newIds).v[slot] = id;
  return true;
}

bool exploreMode() { return push.mode == MIRAGE_RT_MODE_BORDER || push.mode == MIRAGE_RT_MODE_REVERSE; }

// A ray the host sampler would not have made: an inverted interval, which every traversal treats
// as a miss (validRay). Exploration rays that are made are valid, so a skipped slot is one whose ray
// fails validRay (nothing is kept alive across the traversal for it).
RtRay skippedRay() {
  RtRay r;
  r.origin = vec3(0.0);
  r.tnear = 1.0;
  r.dir = vec3(0.0, 0.0, 1.0);
  r.tfar = 0.0;
  return r;
}

// The exploration ray from `origin` towards `target`, or skipped where the host drops it.
RtRay exploreRay(vec3 origin, vec3 target) {
  vec3 d = target - origin;
  if (dot(d, d) < 1e-30) return skippedRay();
  RtRay r;
  r.origin = origin;
  r.tnear = 0.0;
  r.dir = normalize(d);
  r.tfar = 1.0 / 0.0;
  if (!validRay(r)) return skippedRay();
  return r;
}

vec3 worldCorner(uint triangle, uint corner) {
  return RtVec3Ref(RtExploreSourceRef(push.cell).s.triangles).v[3u * triangle + corner];
}

// ABS slot `index`: border point index % raysPerItem of item index / raysPerItem (gvs_explore.h);
// false for a degenerate triangle (no border to follow).
bool borderTarget(uint index, out vec3 origin, out vec3 target) {
  RtExploreSourceRef src = RtExploreSourceRef(push.cell);
  uint per = src.s.raysPerItem;
  RtBorderItem item = RtBorderItemRef(src.s.items).v[index / per];
  origin = item.origin;
  vec3 v0 = worldCorner(item.triangle, 0u), v1 = worldCorner(item.triangle, 1u), v2 = worldCorner(item.triangle, 2u);
  vec3 n = cross(v1 - v0, v2 - v0);
  if (dot(n, n) < 1e-30) return false;
  vec3 en0 = absEdgeNormal(v0, v1, v2, n), en1 = absEdgeNormal(v1, v2, v0, n), en2 = absEdgeNormal(v2, v0, v1, n);
  float delta = absDelta(v0, v1, v2, src.s.absDeltaTriangle, src.s.absDeltaAbsolute);
  target = absPoint(v0, v1, v2, en0, en1, en2, delta, index % per, src.s.absEdgeSamples);
  return true;
}

RtRay borderRay(uint index) {
  vec3 origin, target;
  return borderTarget(index, origin, target) ? exploreRay(origin, target) : skippedRay();
}

// Point `s` (0..1) along the cell's edges, by length (the host's edgePoint).
vec3 cellEdgePoint(float s) {
  RtExploreSourceRef src = RtExploreSourceRef(push.cell);
  float at = s * src.s.edgeLength;
  for (uint e = 0u; e < src.s.edgeCount; ++e) {
    float len = src.s.edges[e].len;
    if (at <= len) return mix(src.s.edges[e].a, src.s.edges[e].b, len > 0.0 ? at / len : 0.0);
    at -= len;
  }
  return src.s.edges[src.s.edgeCount - 1u].b;
}

// RS ray `index`: origin index % raysPerItem of seed index / raysPerItem, aimed at its target.
RtRay reverseRay(uint index) {
  RtExploreSourceRef src = RtExploreSourceRef(push.cell);
  uint per = src.s.raysPerItem, j = index % per;
  RtReverseItem item = RtReverseItemRef(src.s.items).v[index / per];
  uint64_t seed = src.s.firstSeed + uint64_t(index / per);
  vec3 o;
  if (j < src.s.rsEdgeSamples) { // evenly along the edges, shifted per seed
    o = cellEdgePoint((float(j) + radicalInverse(seed, 2u)) / float(src.s.rsEdgeSamples));
  } else { // Halton points on the surface (RandomizedHalton<3>: index + 1)
    uint64_t h = seed * uint64_t(src.s.rsAreaSamples) + uint64_t(j - src.s.rsEdgeSamples) + 1UL;
    o = cellSurfacePoint(wrapUnit(radicalInverse(h, 2u) + src.s.rsOffset0),
                         wrapUnit(radicalInverse(h, 3u) + src.s.rsOffset1),
                         wrapUnit(radicalInverse(h, 5u) + src.s.rsOffset2));
  }
  vec3 d = item.target - o;
  if (dot(d, d) < 1e-30) return skippedRay();
  // Inside the occluder's shadow on the cell: the occluder blocks this origin too.
  if (item.occluder != MIRAGE_RT_NO_HIT &&
      segmentHitsTriangle(item.target, o - item.target, worldCorner(item.occluder, 0u), worldCorner(item.occluder, 1u),
                          worldCorner(item.occluder, 2u)))
    return skippedRay();
  return exploreRay(o, item.target);
}

RtRay loadRay(uint index) {
  if (push.mode == MIRAGE_RT_MODE_GENERATED) return generatedRay(index);
  if (push.mode == MIRAGE_RT_MODE_CELL) return cellRay(index);
  if (push.mode == MIRAGE_RT_MODE_BORDER) return borderRay(index);
  if (push.mode == MIRAGE_RT_MODE_REVERSE) return reverseRay(index);
  RtRay ray;
  if (push.mode == MIRAGE_RT_MODE_COMPACT) { // 24 bytes: origin, direction; [0, inf)
    RtVec2Ref rays = RtVec2Ref(push.rays);
    vec2 a = rays.v[3u * index], b = rays.v[3u * index + 1u], c = rays.v[3u * index + 2u];
    ray.origin = vec3(a, b.x);
    ray.dir = vec3(b.y, c);
    ray.tnear = 0.0;
    ray.tfar = 1.0 / 0.0;
    return ray;
  }
  // Two 16-byte loads (the buffer is 16-byte aligned): eight scalar loads through the scalar-layout
  // reference cost 4x the memory requests, and the rays live in host-visible memory (PCIe).
  RtVec4Ref rays = RtVec4Ref(push.rays);
  vec4 a = rays.v[2u * index], b = rays.v[2u * index + 1u];
  ray.origin = a.xyz;
  ray.tnear = a.w;
  ray.dir = b.xyz;
  ray.tfar = b.w;
  return ray;
}

// Counts the rays an exploration launch traced (not skipped): one atomic per subgroup where the
// stage has subgroup ballots (the compute traversal), else one per ray.
void countTraced(bool traced) {
#ifdef MIRAGE_RT_SUBGROUP_COUNT
  uvec4 lanes = subgroupBallot(traced);
  if (subgroupElect()) {
    uint n = subgroupBallotBitCount(lanes);
    if (n > 0u) atomicAdd(RtCountersRef(push.counters).c.traced, n);
  }
#else
  if (traced) atomicAdd(RtCountersRef(push.counters).c.traced, 1u);
#endif
}

// MODE_BORDER / MODE_REVERSE after the hit: the count, the generated ray (tests), and for ABS the
// discontinuity test (missed, or hit nearer than the target by more than rsDeltaRelative).
// The border point is made again here rather than kept through the traversal (registers).
void finishExplore(uint index, RtRay ray, RtHit hit) {
  RtExploreSourceRef src = RtExploreSourceRef(push.cell);
  bool skipped = !validRay(ray);
  countTraced(!skipped);
  if (src.s.rays != 0ul) {
    RtRay out_ = ray;
    if (skipped) out_.tfar = -1.0;
    RtRayRef(src.s.rays).v[index] = out_;
  }
  if (skipped || push.mode != MIRAGE_RT_MODE_BORDER) return;
  vec3 origin, target;
  borderTarget(index, origin, target);
  float dist = length(target - ray.origin);
  if (hit.triangle != MIRAGE_RT_NO_HIT && hit.t >= dist * (1.0 - src.s.rsDeltaRelative)) return;
  uint slot = atomicAdd(RtCountersRef(push.counters).c.discontinuities, 1u);
  RtDiscontinuity d;
  d.target = target;
  d.occluder = hit.triangle;
  d.ray = index;
  RtDiscontinuityRef(src.s.discontinuities).v[slot] = d;
}

// Everything after the traversal: the closest hit and the see-through candidates in front of it
// go into the record set (first insertions flagged), are checked against the require set, claim
// their first ray (MODE_CELL) and are written out.
void finishRay(uint index, RtRay ray, Payload payload) {
  RtHit hit;
  hit.triangle = payload.triangle;
  hit.t = payload.triangle == MIRAGE_RT_NO_HIT ? ray.tfar : payload.t;
  hit.flags = 0u;
  hit.seeThrough = MIRAGE_RT_NO_HIT;
  bool recording = push.record != 0ul, requiring = push.require != 0ul;
  if (hit.triangle != MIRAGE_RT_NO_HIT) {
    if (recording && insert(hit.triangle)) hit.flags |= MIRAGE_RT_HIT_NEW;
    if (requiring && !testBit(push.require, hit.triangle)) hit.flags |= MIRAGE_RT_HIT_MISSING;
  }
  // See-through candidates count only in front of the closest opaque hit.
  float nearest = hit.t;
  bool nearestNew = false;
  for (uint c = 0u; c < payload.count; ++c) {
    uint id = payload.ids[c];
    float t = payload.ts[c];
    if (hit.triangle != MIRAGE_RT_NO_HIT && t >= hit.t) continue;
    bool fresh = recording && insert(id);
    if (requiring && !testBit(push.require, id)) hit.flags |= MIRAGE_RT_HIT_MISSING;
    if (hit.seeThrough == MIRAGE_RT_NO_HIT || t < nearest) {
      hit.seeThrough = id;
      nearest = t;
      nearestNew = fresh;
    } else if (id == hit.seeThrough) {
      nearestNew = nearestNew || fresh;
    }
  }
  if (nearestNew) hit.flags |= MIRAGE_RT_HIT_SEE_THROUGH_NEW;
  if (push.mode == MIRAGE_RT_MODE_CELL || exploreMode()) {
    if (hit.triangle != MIRAGE_RT_NO_HIT) claim(hit.triangle, index);
    if (hit.seeThrough != MIRAGE_RT_NO_HIT) claim(hit.seeThrough, index);
  }
  if (exploreMode()) finishExplore(index, ray, hit);
  if (push.hits != 0ul) // one 16-byte store, not four 4-byte ones into host-visible memory
    RtUVec4Ref(push.hits).v[index] = uvec4(hit.triangle, floatBitsToUint(hit.t), hit.flags, hit.seeThrough);
}
#endif
