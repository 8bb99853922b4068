#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
// Radix sort pass 1/3: the 256-bin histogram of one 8-bit digit per block of MIRAGE_RADIX_BLOCK
// keys, written digit-major so that the scan pass finds one digit's blocks side by side.
#include "mirage/shaderio/radix_sort.h"

layout(local_size_x = MIRAGE_RADIX_THREADS) in;
layout(push_constant, scalar) uniform Push { RadixSortPush push; };

shared uint bins[MIRAGE_RADIX_BINS];

void main() {
  uint t = gl_LocalInvocationID.x, block = gl_WorkGroupID.x;
  bins[t] = 0u; // MIRAGE_RADIX_THREADS == MIRAGE_RADIX_BINS
  barrier();
  RadixU64Ref keys = RadixU64Ref(push.keysIn);
  uint first = block * MIRAGE_RADIX_BLOCK;
  for (uint r = 0u; r < MIRAGE_RADIX_ROUNDS; ++r) {
    uint i = first + r * MIRAGE_RADIX_THREADS + t;
    if (i < push.count) atomicAdd(bins[radixDigit(keys.v[i], push.shift, push.descending)], 1u);
  }
  barrier();
  RadixU32Ref(push.histograms).v[t * push.blockCount + block] = bins[t];
}
