// Compute traversal of the ray backend: the same rays, sets and results as the ray-tracing
// pipeline (vis_trace_common.glsl), traversing a binary BVH built on the host (ray_bvh.cpp) in
// the Aila-Laine layout (one 64-byte node holds both children's boxes). While-while traversal
// (Aila & Laine 2009): descend through inner nodes, postpone the first leaf met and keep
// descending until every lane of the subgroup holds a leaf, then intersect leaves, so lanes
// diverge less between box tests and triangle tests. Children are visited nearest first and a
// closer opaque hit shrinks the interval; see-through triangles are remembered, not committed.
// Included by vis_trace.comp, vis_trace_shared_stack.comp (the stack in shared memory) and
// vis_trace_bvh4.comp (MIRAGE_RT_BVH4: 4-wide nodes, RtBvh4Node) and vis_trace_bvh8.comp
// (MIRAGE_RT_BVH8: compressed 8-wide nodes, RtBvh8Node; its traversal is vis_trace_bvh8.glsl).
#extension GL_KHR_shader_subgroup_vote : require
#extension GL_KHR_shader_subgroup_ballot : require
#define MIRAGE_RT_SUBGROUP_COUNT // countTraced: one atomic per subgroup
#include "vis_trace_common.glsl"

layout(local_size_x = MIRAGE_RT_COMPUTE_GROUP) in;

// The traversal stack: a per-thread array (local memory, cached in L1 on NVIDIA), or with
// MIRAGE_RT_SHARED_STACK (vis_trace_shared_stack.comp) shared memory, one column per thread so the
// lanes of a subgroup touch distinct banks (16 KiB per workgroup).
#ifdef MIRAGE_RT_SHARED_STACK
shared uint stackMemory[MIRAGE_RT_BVH_STACK * MIRAGE_RT_COMPUTE_GROUP];
#define STACK(i) stackMemory[(i) * MIRAGE_RT_COMPUTE_GROUP + gl_LocalInvocationIndex]
#else
#define STACK(i) stack[i]
#endif

// Slab test of one box: the entry distance, or +inf when the ray misses it within [tnear, tbest].
// The host pads every box by a few ulps of its coordinates, which covers the fma rounding.
float enterBox(vec3 lo, vec3 hi, vec3 idir, vec3 ood, float tnear, float tbest) {
  vec3 a = fma(lo, idir, -ood), b = fma(hi, idir, -ood);
  vec3 mn = min(a, b), mx = max(a, b);
  float entry = max(max(mn.x, mn.y), max(mn.z, tnear));
  float exit = min(min(mx.x, mx.y), min(mx.z, tbest));
  return entry <= exit ? entry : 1.0 / 0.0;
}

#ifdef MIRAGE_RT_BVH4
// Compare-exchange of two lanes of (key, ref) in the 4-wide node visit (a swizzle swap).
#define SORT2(a, b)                                                                                    \
  if (key.b < key.a) {                                                                                 \
    key.a##b = key.b##a;                                                                               \
    ref.a##b = ref.b##a;                                                                               \
  }
#endif

// A direction component of zero would give inf * 0 = NaN in the slab test: use a tiny one.
float safeInverse(float d) { return 1.0 / (abs(d) > 1e-20 ? d : (d >= 0.0 ? 1e-20 : -1e-20)); }
vec3 safeInverse(vec3 d) { return vec3(safeInverse(d.x), safeInverse(d.y), safeInverse(d.z)); }

// What every traversal starts from: no hit, no see-through candidate, t at the ray's far end (also
// the answer for an invalid ray or an empty scene).
Payload missPayload(RtRay ray) {
  Payload p;
  p.triangle = MIRAGE_RT_NO_HIT;
  p.t = ray.tfar;
  p.count = 0u;
  return p;
}

// Leaf triangle k (RtBvhTriangle): Moller-Trumbore, both faces; NaNs (degenerate triangles) fail
// every comparison. An opaque hit shrinks the interval, a see-through one is remembered. Returns
// the triangle's flags.
uint testTriangle(RtVec4Ref tris, uint k, RtRay ray, float tnear, inout float tbest, inout Payload p,
                  bool onlyRequired) {
  vec4 a = tris.v[k * 3u], b = tris.v[k * 3u + 1u], c = tris.v[k * 3u + 2u];
  uint id = floatBitsToUint(a.w), flags = floatBitsToUint(b.w);
  vec3 e1 = b.xyz - a.xyz, e2 = c.xyz - a.xyz;
  vec3 pv = cross(ray.dir, e2);
  float inv = 1.0 / dot(e1, pv);
  vec3 s = ray.origin - a.xyz;
  float u = dot(s, pv) * inv;
  vec3 q = cross(s, e1);
  float v = dot(ray.dir, q) * inv;
  float t = dot(e2, q) * inv;
  if (u >= 0.0 && v >= 0.0 && u + v <= 1.0 && t >= tnear && t < tbest &&
      (!onlyRequired || testBit(push.require, id))) {
    if ((flags & MIRAGE_RT_BVH_SEE_THROUGH) != 0u) {
      addSeeThrough(p, id, t, tbest);
    } else {
      tbest = t;
      p.triangle = id;
      p.t = t;
    }
  }
  return flags;
}

#ifdef MIRAGE_RT_BVH8
#include "vis_trace_bvh8.glsl"
#else
Payload traverse(RtRay ray) {
  Payload p = missPayload(ray);
  if (!validRay(ray) || push.bvhNodes == 0ul) return p; // no BVH: an empty scene
  RtVec4Ref nodes = RtVec4Ref(push.bvhNodes);
  RtVec4Ref tris = RtVec4Ref(push.bvhTriangles);
  const vec3 idir = safeInverse(ray.dir);
  const vec3 ood = ray.origin * idir;
  const float tnear = ray.tnear;
  float tbest = min(ray.tfar, 3.4e38);
  const bool onlyRequired = push.onlyRequired != 0u;

#ifndef MIRAGE_RT_SHARED_STACK
  uint stack[MIRAGE_RT_BVH_STACK];
#endif
  STACK(0) = MIRAGE_RT_BVH_NONE;
  int sp = 1;
  uint node = 0u;                  // the root is an inner node
  uint leaf = MIRAGE_RT_BVH_NONE; // a postponed leaf, or none
  while (node != MIRAGE_RT_BVH_NONE) {
    while (node < MIRAGE_RT_BVH_NONE) { // inner nodes
#ifdef MIRAGE_RT_BVH4
      // Four boxes as vec4 planes; entry distances of the children hit, +inf for the rest, sorted
      // with a five-comparator network (registers only), the nearest visited, the others pushed.
      uint base = node * 7u;
      vec4 ax = fma(nodes.v[base], vec4(idir.x), vec4(-ood.x));
      vec4 bx = fma(nodes.v[base + 1u], vec4(idir.x), vec4(-ood.x));
      vec4 ay = fma(nodes.v[base + 2u], vec4(idir.y), vec4(-ood.y));
      vec4 by = fma(nodes.v[base + 3u], vec4(idir.y), vec4(-ood.y));
      vec4 az = fma(nodes.v[base + 4u], vec4(idir.z), vec4(-ood.z));
      vec4 bz = fma(nodes.v[base + 5u], vec4(idir.z), vec4(-ood.z));
      uvec4 ref = floatBitsToUint(nodes.v[base + 6u]);
      vec4 entry = max(max(min(ax, bx), min(ay, by)), max(min(az, bz), vec4(tnear)));
      vec4 exit = min(min(max(ax, bx), max(ay, by)), min(max(az, bz), vec4(tbest)));
      bvec4 hit = bvec4(uvec4(lessThanEqual(entry, exit)) & uvec4(notEqual(ref, uvec4(MIRAGE_RT_BVH_NONE))));
      vec4 key = mix(vec4(1.0 / 0.0), entry, hit);
      SORT2(x, y) SORT2(z, w) SORT2(x, z) SORT2(y, w) SORT2(y, z)
      if (key.w < 1.0 / 0.0) STACK(sp++) = ref.w;
      if (key.z < 1.0 / 0.0) STACK(sp++) = ref.z;
      if (key.y < 1.0 / 0.0) STACK(sp++) = ref.y;
      node = key.x < 1.0 / 0.0 ? ref.x : STACK(--sp);
#else
      vec4 a = nodes.v[node * 4u], b = nodes.v[node * 4u + 1u], c = nodes.v[node * 4u + 2u];
      uvec4 children = floatBitsToUint(nodes.v[node * 4u + 3u]);
      float e0 = enterBox(a.xyz, vec3(a.w, b.xy), idir, ood, tnear, tbest);
      float e1 = enterBox(vec3(b.zw, c.x), c.yzw, idir, ood, tnear, tbest);
      bool h0 = e0 < 1.0 / 0.0, h1 = e1 < 1.0 / 0.0;
      if (!h0 && !h1) {
        node = STACK(--sp);
      } else if (h0 && h1) {
        bool swap = e1 < e0; // nearest first
        node = swap ? children.y : children.x;
        STACK(sp++) = swap ? children.x : children.y;
      } else {
        node = h0 ? children.x : children.y;
      }
#endif
      if (node > MIRAGE_RT_BVH_NONE && leaf == MIRAGE_RT_BVH_NONE) { // postpone the leaf
        leaf = node;
        node = STACK(--sp);
      }
      if (subgroupAll(leaf != MIRAGE_RT_BVH_NONE)) break;
    }
    while (leaf != MIRAGE_RT_BVH_NONE) {
      for (uint k = leaf & ~MIRAGE_RT_BVH_LEAF;; ++k)
        if ((testTriangle(tris, k, ray, tnear, tbest, p, onlyRequired) & MIRAGE_RT_BVH_LAST) != 0u) break;
      // Another leaf waiting (the inner loop stopped on one): intersect it too.
      leaf = MIRAGE_RT_BVH_NONE;
      if (node > MIRAGE_RT_BVH_NONE) {
        leaf = node;
        node = STACK(--sp);
      }
    }
  }
  return p;
}
#endif

void traceOne(uint index) {
  RtRay ray = loadRay(index);
  finishRay(index, ray, traverse(ray));
}

void main() {
  if (push.persistent == 0u) {
    uint index = gl_GlobalInvocationID.y * MIRAGE_RT_LAUNCH_WIDTH + gl_GlobalInvocationID.x;
    if (index < push.count) traceOne(index);
    return;
  }
  // Persistent threads: a resident grid loops over the rays, the lanes of a subgroup fetching their
  // next rays together with one atomic (Aila & Laine's batching). Counting the lanes present
  // (ballot) keeps every ray traced even where the lanes have not reconverged.
  for (;;) {
    uvec4 present = subgroupBallot(true);
    uint base = 0u;
    if (subgroupElect())
      base = atomicAdd(RtCountersRef(push.counters).c.nextBatch, subgroupBallotBitCount(present));
    base = subgroupBroadcastFirst(base);
    if (base >= push.count) break;
    uint index = base + subgroupBallotExclusiveBitCount(present);
    if (index < push.count) traceOne(index);
  }
}
