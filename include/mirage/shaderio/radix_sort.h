// Push constants of the GPU sorts (src/gpu/radix_sort.cpp): shared by C++ and GLSL.
#ifndef MIRAGE_SHADERIO_RADIX_SORT_H
#define MIRAGE_SHADERIO_RADIX_SORT_H

#ifdef __cplusplus
#include <cstdint>
namespace mirage::shaderio {
using uint = uint32_t;
#endif

// Keys per work group of the radix passes: 256 invocations × 16 rounds. The histogram and scatter
// passes must agree on it; the scatter's stable ranking works one round of 256 keys at a time.
#define MIRAGE_RADIX_THREADS 256
#define MIRAGE_RADIX_ROUNDS 16
#define MIRAGE_RADIX_BLOCK (MIRAGE_RADIX_THREADS * MIRAGE_RADIX_ROUNDS)
#define MIRAGE_RADIX_BINS 256

struct RadixSortPush {
  uint64_t keysIn;     // uint64[count]: this pass's input keys
  uint64_t keysOut;    // uint64[count]: this pass's output (ping-pong with keysIn)
  uint64_t histograms; // uint[256 * blockCount], digit-major: histograms[digit * blockCount + block]
  uint count;          // keys to sort
  uint shift;          // bit position of this pass's 8-bit digit in the 64-bit key
  uint descending;     // 1: largest key first (the digit is inverted)
  uint blockCount;     // ceil(count / MIRAGE_RADIX_BLOCK)
  uint bitonicJ;       // bitonic baseline: compare distance
  uint bitonicK;       // bitonic baseline: sequence size
};

#ifdef __cplusplus
static_assert(sizeof(RadixSortPush) == 48, "RadixSortPush layout");
} // namespace mirage::shaderio
#else
layout(buffer_reference, scalar, buffer_reference_align = 8) buffer RadixU64Ref { uint64_t v[]; };
layout(buffer_reference, scalar, buffer_reference_align = 4) buffer RadixU32Ref { uint v[]; };

uint radixDigit(uint64_t key, uint shift, uint descending) {
  uint d = uint(key >> shift) & 255u;
  return descending != 0u ? 255u - d : d;
}
#endif

#endif
