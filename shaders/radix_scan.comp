#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
// Radix sort pass 2/3, one work group: invocation d turns digit d's row of block counts into
// exclusive offsets within the digit (a serial loop: the rows are short, blockCount = keys / 4096),
// then one shared-memory scan over the 256 digit totals adds where each digit starts. Afterwards
// histograms[d * blockCount + b] is the first output slot of block b's keys with digit d.
// One work group with one scan keeps the pass cheap where barriers are expensive (lavapipe).
#include "mirage/shaderio/radix_sort.h"

layout(local_size_x = MIRAGE_RADIX_BINS) in;
layout(push_constant, scalar) uniform Push { RadixSortPush push; };

shared uint scan[2][MIRAGE_RADIX_BINS];

void main() {
  uint digit = gl_LocalInvocationID.x;
  RadixU32Ref row = RadixU32Ref(push.histograms + 4ul * uint64_t(digit) * uint64_t(push.blockCount));
  uint total = 0u;
  for (uint b = 0u; b < push.blockCount; ++b) {
    uint count = row.v[b];
    row.v[b] = total;
    total += count;
  }
  // Hillis-Steele inclusive scan of the totals, double-buffered so no step reads what it overwrites.
  uint src = 0u;
  scan[src][digit] = total;
  barrier();
  for (uint offset = 1u; offset < MIRAGE_RADIX_BINS; offset <<= 1) {
    uint v = scan[src][digit];
    if (digit >= offset) v += scan[src][digit - offset];
    scan[1u - src][digit] = v;
    src = 1u - src;
    barrier();
  }
  uint start = scan[src][digit] - total;
  for (uint b = 0u; b < push.blockCount; ++b) row.v[b] += start;
}
