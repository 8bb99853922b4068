// Morton codes and the parallel radix sort of ids by key (morton.h).
#include "morton.h"

#include <algorithm>

#include <tbb/parallel_for.h>

namespace mirage::lod::detail {

std::vector<uint32_t> sortIdsByKey(std::vector<uint32_t> key) {
  constexpr size_t kBlock = size_t(1) << 16, kBuckets = 1024;
  size_t n = key.size(), blocks = (n + kBlock - 1) / kBlock;
  std::vector<uint32_t> id(n), keyOut(n), idOut(n), start(blocks * kBuckets);
  for (size_t i = 0; i < n; ++i) id[i] = uint32_t(i);
  for (uint32_t shift = 0; shift < 30; shift += 10) {
    tbb::parallel_for(size_t(0), blocks, [&](size_t b) {
      uint32_t* count = &start[b * kBuckets];
      std::fill(count, count + kBuckets, 0u);
      for (size_t i = b * kBlock; i < std::min(n, (b + 1) * kBlock); ++i) ++count[key[i] >> shift & (kBuckets - 1)];
    });
    uint32_t sum = 0; // exclusive prefix in (bucket, block) order: stable
    for (size_t d = 0; d < kBuckets; ++d)
      for (size_t b = 0; b < blocks; ++b) {
        uint32_t c = start[b * kBuckets + d];
        start[b * kBuckets + d] = sum;
        sum += c;
      }
    tbb::parallel_for(size_t(0), blocks, [&](size_t b) {
      uint32_t* next = &start[b * kBuckets];
      for (size_t i = b * kBlock; i < std::min(n, (b + 1) * kBlock); ++i) {
        uint32_t at = next[key[i] >> shift & (kBuckets - 1)]++;
        keyOut[at] = key[i], idOut[at] = id[i];
      }
    });
    key.swap(keyOut);
    id.swap(idOut);
  }
  return id;
}

} // namespace mirage::lod::detail
