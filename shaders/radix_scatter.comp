#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
// Radix sort pass 3/3: every block writes its keys to their sorted places, stably.
// Destination = (keys of smaller digits overall) + (keys of this digit in earlier blocks)
//             + (keys of this digit earlier in this block).
// The last term needs each key's rank among equal digits of its round of 256 keys. Subgroup
// ballots would give it, but the subgroup size differs between devices (8 on lavapipe, 32 on
// NVIDIA), so the ballot is emulated in shared memory: one 256-bit mask per digit, one bit per
// invocation; the rank is the popcount of the bits below the invocation's own.
#include "mirage/shaderio/radix_sort.h"

layout(local_size_x = MIRAGE_RADIX_THREADS) in;
layout(push_constant, scalar) uniform Push { RadixSortPush push; };

const uint kWords = MIRAGE_RADIX_THREADS / 32u;
shared uint masks[MIRAGE_RADIX_BINS * kWords]; // 8 KiB
shared uint offsets[MIRAGE_RADIX_BINS];        // next destination per digit
shared uint scan[2][MIRAGE_RADIX_BINS];

void main() {
  uint t = gl_LocalInvocationID.x, block = gl_WorkGroupID.x;
  // Exclusive prefix over the digit totals (every block recomputes it: 256 values).
  uint total = RadixU32Ref(push.totals).v[t];
  uint src = 0u;
  scan[src][t] = total;
  barrier();
  for (uint offset = 1u; offset < MIRAGE_RADIX_BINS; offset <<= 1) {
    uint v = scan[src][t];
    if (t >= offset) v += scan[src][t - offset];
    scan[1u - src][t] = v;
    src = 1u - src;
    barrier();
  }
  offsets[t] = scan[src][t] - total + RadixU32Ref(push.histograms).v[t * push.blockCount + block];
  for (uint w = 0u; w < kWords; ++w) masks[t * kWords + w] = 0u;
  barrier();

  RadixU64Ref keysIn = RadixU64Ref(push.keysIn), keysOut = RadixU64Ref(push.keysOut);
  uint word = t / 32u, bit = 1u << (t % 32u);
  uint first = block * MIRAGE_RADIX_BLOCK;
  for (uint r = 0u; r < MIRAGE_RADIX_ROUNDS; ++r) {
    uint i = first + r * MIRAGE_RADIX_THREADS + t;
    bool valid = i < push.count;
    uint64_t key = valid ? keysIn.v[i] : uint64_t(0);
    uint digit = radixDigit(key, push.shift, push.descending);
    if (valid) atomicOr(masks[digit * kWords + word], bit);
    barrier();
    uint rank = 0u, same = 0u;
    if (valid) {
      for (uint w = 0u; w < kWords; ++w) {
        uint m = masks[digit * kWords + w];
        if (w < word) rank += bitCount(m);
        same += bitCount(m);
      }
      rank += bitCount(masks[digit * kWords + word] & (bit - 1u));
      keysOut.v[offsets[digit] + rank] = key;
    }
    barrier(); // every rank is read before the last key of each digit moves the offset on
    if (valid && rank + 1u == same) {
      offsets[digit] += same;
      for (uint w = 0u; w < kWords; ++w) masks[digit * kWords + w] = 0u;
    }
    barrier();
  }
}
