// Traversal of the compressed 8-wide BVH (RtBvh8Node, shaderio/rays.h), after Ylitie, Karras &
// Laine 2017: one 80-byte node (five 16-byte loads) tests eight quantized boxes as two groups of
// four vec4 slab tests. The children hit become one 32-bit mask: triangles in bits 0..23 (each
// leaf's run of up to three), inner children in bits 24..31 ordered so that the highest bit is the
// child nearest first for the ray's direction octant (the host sorted the slots by octant). The
// stack holds node groups (the children's base index, the hit bits left | imask), one push per
// level at most; triangles are tested as soon as their node is opened, or with
// MIRAGE_RT_BVH8_POSTPONE (vis_trace_bvh8_postpone.comp) Ylitie et al.'s triangle postponing: when
// fewer than a fifth of the subgroup's lanes are testing triangles, a lane pushes its remaining
// triangles as a group of their own (hit bits only below bit 24) and goes on down the tree, so the
// subgroup does not run the triangle loop for a few lanes; popped later, such a group is tested
// then. Ties may then resolve differently from run to run. Included by vis_trace_compute.glsl
// (MIRAGE_RT_BVH8), which provides testTriangle, the ray sources and main().

Payload traverse(RtRay ray) {
  Payload p = missPayload(ray);
  if (!validRay(ray) || push.bvhNodes == 0ul) return p; // no BVH: an empty scene
  RtVec4Ref nodes = RtVec4Ref(push.bvhNodes);
  RtVec4Ref tris = RtVec4Ref(push.bvhTriangles);
  const vec3 idir = safeInverse(ray.dir);
  const float tnear = ray.tnear;
  float tbest = min(ray.tfar, 3.4e38);
  const bool onlyRequired = push.onlyRequired != 0u;
  // Slot s of an inner child lands on bit 24 + (s ^ octinv): slot `octant` (nearest first for
  // this direction) on bit 31, the first popped.
  const uint octinv =
      7u - ((ray.dir.x < 0.0 ? 1u : 0u) | (ray.dir.y < 0.0 ? 2u : 0u) | (ray.dir.z < 0.0 ? 4u : 0u));
  const uvec4 byteShift = uvec4(0u, 8u, 16u, 24u);

#ifdef MIRAGE_RT_BVH8_POSTPONE
  // Node groups (one per level) and postponed triangle groups; when full, triangles are not postponed.
  uvec2 stack[2 * MIRAGE_RT_BVH8_STACK];
  const uint minLanes = (gl_SubgroupSize + 4u) / 5u; // a fifth, rounded up: 7 of 32, 2 of 8 (lavapipe)
#else
  uvec2 stack[MIRAGE_RT_BVH8_STACK];
#endif
  int sp = 0;
  uvec2 group = uvec2(0u, 0x80000000u); // the root: node 0, one inner "child" on the top bit
  for (;;) {
#ifdef MIRAGE_RT_BVH8_POSTPONE
    if (group.y <= 0x00ffffffu) { // a postponed triangle group, popped
      uint left = group.y;
      for (; left != 0u; left &= left - 1u)
        testTriangle(tris, group.x + uint(findLSB(left)), ray, tnear, tbest, p, onlyRequired);
      if (sp == 0) break;
      group = stack[--sp];
      continue;
    }
#endif
    // The next inner child of the group: its index is the base plus the inner slots below it.
    const uint bit = uint(findMSB(group.y));
    group.y &= ~(1u << bit);
    const uint slot = (bit - 24u) ^ octinv;
    const uint index = group.x + bitCount(group.y & 0xffu & ((1u << slot) - 1u));
    if (group.y > 0x00ffffffu) stack[sp++] = group;

    const uint base = index * 5u;
    const vec4 n0 = nodes.v[base];
    const uvec4 n1 = floatBitsToUint(nodes.v[base + 1u]);
    const uvec4 qx = floatBitsToUint(nodes.v[base + 2u]);
    const uvec4 qy = floatBitsToUint(nodes.v[base + 3u]);
    const uvec4 qz = floatBitsToUint(nodes.v[base + 4u]);
    const uint packed = floatBitsToUint(n0.w);
    // Step 2^e per axis straight from the biased exponent byte; box planes at fma(q, step/d, (origin - o)/d).
    const vec3 step = uintBitsToFloat(((uvec3(packed) >> uvec3(0u, 8u, 16u)) & 0xffu) << 23);
    const vec3 scaled = step * idir;
    const vec3 shift = (n0.xyz - ray.origin) * idir;
    uint hitMask = 0u;
    for (uint h = 0u; h < 2u; ++h) { // slots 4h .. 4h + 3
      const uint meta4 = h == 0u ? n1.z : n1.w;
      const vec4 loX = vec4((uvec4(h == 0u ? qx.x : qx.y) >> byteShift) & 0xffu);
      const vec4 hiX = vec4((uvec4(h == 0u ? qx.z : qx.w) >> byteShift) & 0xffu);
      const vec4 loY = vec4((uvec4(h == 0u ? qy.x : qy.y) >> byteShift) & 0xffu);
      const vec4 hiY = vec4((uvec4(h == 0u ? qy.z : qy.w) >> byteShift) & 0xffu);
      const vec4 loZ = vec4((uvec4(h == 0u ? qz.x : qz.y) >> byteShift) & 0xffu);
      const vec4 hiZ = vec4((uvec4(h == 0u ? qz.z : qz.w) >> byteShift) & 0xffu);
      vec4 ax = fma(loX, vec4(scaled.x), vec4(shift.x)), bx = fma(hiX, vec4(scaled.x), vec4(shift.x));
      vec4 ay = fma(loY, vec4(scaled.y), vec4(shift.y)), by = fma(hiY, vec4(scaled.y), vec4(shift.y));
      vec4 az = fma(loZ, vec4(scaled.z), vec4(shift.z)), bz = fma(hiZ, vec4(scaled.z), vec4(shift.z));
      vec4 entry = max(max(min(ax, bx), min(ay, by)), max(min(az, bz), vec4(tnear)));
      vec4 exit = min(min(max(ax, bx), max(ay, by)), min(max(az, bz), vec4(tbest)));
      const bvec4 hit = lessThanEqual(entry, exit);
      for (uint j = 0u; j < 4u; ++j) {
        const uint meta = (meta4 >> (8u * j)) & 0xffu; // 0 for an empty slot: no bits
        uint position = meta & 31u;
        position ^= position >= 24u ? octinv : 0u;
        if (hit[j]) hitMask |= (meta >> 5) << position;
      }
    }
    group = uvec2(n1.x, (hitMask & 0xff000000u) | (packed >> 24));
    for (uint left = hitMask & 0x00ffffffu; left != 0u; left &= left - 1u) {
#ifdef MIRAGE_RT_BVH8_POSTPONE
      // Postponed only while there is a node group to go on with and room on the stack.
      if (group.y > 0x00ffffffu && sp < 2 * MIRAGE_RT_BVH8_STACK &&
          subgroupBallotBitCount(subgroupBallot(true)) < minLanes) {
        stack[sp++] = uvec2(n1.y, left);
        break;
      }
#endif
      testTriangle(tris, n1.y + uint(findLSB(left)), ray, tnear, tbest, p, onlyRequired);
    }
    if (group.y <= 0x00ffffffu) {
      if (sp == 0) break;
      group = stack[--sp];
    }
  }
  return p;
}
