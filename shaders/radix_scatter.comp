#version 460
#extension GL_EXT_buffer_reference : require
#extension GL_EXT_scalar_block_layout : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require
// Radix sort pass 3/3: every block writes its keys to their sorted places, stably.
// Destination = (first slot of this block's keys with this digit, from the scan pass)
//             + (keys of this digit earlier in this block).
// The last term needs each key's rank among equal digits of its round of 256 keys. Subgroup
// ballots would give it, but the subgroup size differs between devices (8 on lavapipe, 32 on
// NVIDIA), so the ballot is emulated in shared memory: one 256-bit mask per digit, one bit per
// invocation; the rank is the popcount of the bits below the invocation's own. Two mask sets
// alternate between rounds, so a round needs two barriers, not three.
#include "mirage/shaderio/radix_sort.h"

layout(local_size_x = MIRAGE_RADIX_THREADS) in;
layout(push_constant, scalar) uniform Push { RadixSortPush push; };

const uint kWords = MIRAGE_RADIX_THREADS / 32u;
shared uint masks[2][MIRAGE_RADIX_BINS * kWords]; // 16 KiB
shared uint offsets[MIRAGE_RADIX_BINS];           // next destination per digit

void main() {
  uint t = gl_LocalInvocationID.x, block = gl_WorkGroupID.x;
  offsets[t] = RadixU32Ref(push.histograms).v[t * push.blockCount + block]; // THREADS == BINS
  for (uint w = 0u; w < kWords; ++w) masks[0][t * kWords + w] = masks[1][t * kWords + w] = 0u;
  barrier();

  RadixU64Ref keysIn = RadixU64Ref(push.keysIn), keysOut = RadixU64Ref(push.keysOut);
  uint word = t / 32u, bit = 1u << (t % 32u);
  uint first = block * MIRAGE_RADIX_BLOCK;
  for (uint r = 0u; r < MIRAGE_RADIX_ROUNDS; ++r) {
    uint set = r & 1u;
    uint i = first + r * MIRAGE_RADIX_THREADS + t;
    bool valid = i < push.count;
    uint64_t key = valid ? keysIn.v[i] : uint64_t(0);
    uint digit = radixDigit(key, push.shift, push.descending);
    if (valid) atomicOr(masks[set][digit * kWords + word], bit);
    barrier(); // masks complete; last round's offset updates visible
    uint rank = 0u, same = 0u;
    if (valid) {
      for (uint w = 0u; w < kWords; ++w) {
        uint m = masks[set][digit * kWords + w];
        if (w < word) rank += bitCount(m);
        same += bitCount(m);
      }
      rank += bitCount(masks[set][digit * kWords + word] & (bit - 1u));
      keysOut.v[offsets[digit] + rank] = key;
    }
    barrier(); // every rank and offset is read before the last key of each digit moves them on
    if (valid && rank + 1u == same) {
      offsets[digit] += same;
      // This set is next used two rounds on, after the next round's first barrier.
      for (uint w = 0u; w < kWords; ++w) masks[set][digit * kWords + w] = 0u;
    }
  }
}
