#pragma once
// A portable GPU LSD radix sort of 64-bit keys: 8-bit digits, per-block histograms, a scan per
// digit and a stable scatter (ballots emulated in shared memory, so any subgroup size works;
// 17 KiB of shared memory). Suited to up to a few million keys: the scan walks each digit's
// blocks serially. Stable, so a 32-bit key with a 32-bit payload sorts as
// (key << 32 | payload) with digitMask 0xF0. A bitonic sort is kept as the measured baseline.
#include <cstdint>

#include "mirage/gpu/memory.h"
#include "mirage/gpu/vk.h"

namespace mirage::gpu {

class Context;

struct RadixSortOptions {
  bool descending = false;   // largest key first
  uint32_t digitMask = 0xFF; // bit d: sort on bits [8d, 8d + 8); skip digits that are equal in every key
};

// Digits needed for keys whose low word is below `lowLimit` (an index) and whose high word is any
// 32-bit value (e.g. float bits of a non-negative number): the sampler's (radius << 32 | texel).
uint32_t digitMaskForIndexBelow(uint32_t lowLimit);

class RadixSort {
public:
  // Scratch (ping-pong keys and histograms) for up to `maxCount` keys.
  RadixSort(Context& context, uint32_t maxCount);

  uint32_t maxCount() const { return maxCount_; }

  // Sorts `count` uint64 keys at the start of `keys` (a storage buffer with TRANSFER_DST).
  // barriers: waits for earlier compute and transfer writes; the caller adds a barrier before
  // reading the keys (the last command is a compute dispatch or a transfer copy).
  void cmdSort(VkCommandBuffer cmd, const Buffer& keys, uint32_t count, const RadixSortOptions& options = {});

  // Baseline: bitonic sort of `count` keys, count a power of two (the caller pads with keys that
  // sort last). One dispatch per merge step. Same barrier contract as cmdSort.
  void cmdBitonicSort(VkCommandBuffer cmd, const Buffer& keys, uint32_t count, bool descending);

  // Dispatches of the last cmdSort / cmdBitonicSort (for benchmarks).
  uint32_t lastDispatches() const { return lastDispatches_; }

private:
  uint32_t maxCount_;
  Unique<VkPipelineLayout> layout_;
  Unique<VkPipeline> histogram_, scan_, scatter_, bitonic_;
  Buffer scratch_, histograms_;
  uint32_t lastDispatches_ = 0;
};

} // namespace mirage::gpu
