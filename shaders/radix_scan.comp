#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
// Radix sort pass 2/3: one work group per digit turns that digit's row of block counts into an
// exclusive prefix sum (chunks of 256 with a running carry) and writes the digit's total. The
// scatter pass adds the prefix over the 256 totals itself.
#include "mirage/shaderio/radix_sort.h"

layout(local_size_x = MIRAGE_RADIX_THREADS) in;
layout(push_constant, scalar) uniform Push { RadixSortPush push; };

shared uint scan[2][MIRAGE_RADIX_THREADS];

void main() {
  uint t = gl_LocalInvocationID.x, digit = gl_WorkGroupID.x;
  RadixU32Ref row = RadixU32Ref(push.histograms + 4ul * uint64_t(digit) * uint64_t(push.blockCount));
  uint carry = 0u;
  for (uint base = 0u; base < push.blockCount; base += MIRAGE_RADIX_THREADS) {
    uint i = base + t;
    uint value = i < push.blockCount ? row.v[i] : 0u;
    // Hillis-Steele inclusive scan, double-buffered so no step reads what it overwrites.
    uint src = 0u;
    scan[src][t] = value;
    barrier();
    for (uint offset = 1u; offset < MIRAGE_RADIX_THREADS; offset <<= 1) {
      uint v = scan[src][t];
      if (t >= offset) v += scan[src][t - offset];
      scan[1u - src][t] = v;
      src = 1u - src;
      barrier();
    }
    uint inclusive = scan[src][t];
    if (i < push.blockCount) row.v[i] = carry + inclusive - value;
    carry += scan[src][MIRAGE_RADIX_THREADS - 1u];
    barrier(); // the next chunk overwrites scan[0]
  }
  if (t == 0u) RadixU32Ref(push.totals).v[digit] = carry;
}
