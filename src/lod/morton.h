#pragma once
// Morton codes and the radix sort of ids by them, for the builder's level-0 chunks.
#include <cstdint>
#include <vector>

namespace mirage::lod::detail {

// Bits 0..9 of x moved to bits 0, 3, 6, ..., 27 (one axis of a 30-bit Morton code).
inline uint32_t spreadBits(uint32_t x) {
  x &= 0x3ffu;
  x = (x | x << 16) & 0x030000ffu;
  x = (x | x << 8) & 0x0300f00fu;
  x = (x | x << 4) & 0x030c30c3u;
  x = (x | x << 2) & 0x09249249u;
  return x;
}

// Ids 0..n-1 sorted by key (ties by id), for keys below 2^30 (Morton codes): a stable parallel
// LSD radix sort, three passes of 10 bits with per-block histograms. Same order as sorting
// (key, id) pairs, at a fraction of parallel_sort's instructions (0.2 G on the dragon).
std::vector<uint32_t> sortIdsByKey(std::vector<uint32_t> key);

} // namespace mirage::lod::detail
