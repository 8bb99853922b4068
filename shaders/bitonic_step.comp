#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
// One bitonic merge step (sequence size bitonicK, distance bitonicJ) over count = 2^m 64-bit keys:
// the baseline the radix sort replaced, kept for `mirage bench surfels-sort` and
// `mirage surfels --sort bitonic`.
#include "mirage/shaderio/radix_sort.h"

layout(local_size_x = 256) in;
layout(push_constant, scalar) uniform Push { RadixSortPush push; };

void main() {
  RadixU64Ref keys = RadixU64Ref(push.keysIn);
  for (uint i = gl_GlobalInvocationID.x; i < push.count; i += gl_NumWorkGroups.x * 256) {
    uint l = i ^ push.bitonicJ;
    if (l <= i) continue;
    uint64_t a = keys.v[i], b = keys.v[l];
    // Runs alternate direction: the first half of each K-sequence goes the final direction.
    bool finalDirection = ((i & push.bitonicK) == 0u) == (push.descending != 0u);
    if (finalDirection ? a < b : a > b) {
      keys.v[i] = b;
      keys.v[l] = a;
    }
  }
}
