#include "mirage/gpu/radix_sort.h"

#include <algorithm>
#include <bit>

#include "mirage/gpu/commands.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/pipeline.h"
#include "mirage/shaderio/radix_sort.h"

namespace mirage::gpu {

namespace sio = mirage::shaderio;

namespace {

uint32_t blocksFor(uint32_t count) { return (count + MIRAGE_RADIX_BLOCK - 1) / MIRAGE_RADIX_BLOCK; }

void cmdComputeBarrier(VkCommandBuffer cmd) {
  cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                   VK_ACCESS_2_SHADER_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                   VK_ACCESS_2_SHADER_READ_BIT | VK_ACCESS_2_SHADER_WRITE_BIT | VK_ACCESS_2_TRANSFER_READ_BIT |
                       VK_ACCESS_2_TRANSFER_WRITE_BIT);
}

} // namespace

uint32_t digitMaskForIndexBelow(uint32_t lowLimit) {
  uint32_t bits = lowLimit > 1 ? uint32_t(std::bit_width(lowLimit - 1)) : 0;
  uint32_t lowDigits = (bits + 7) / 8;
  return 0xF0u | ((1u << lowDigits) - 1u);
}

RadixSort::RadixSort(Context& context, uint32_t maxCount) : maxCount_(maxCount) {
  layout_ = createPipelineLayout(context, {}, sizeof(sio::RadixSortPush), VK_SHADER_STAGE_COMPUTE_BIT);
  histogram_ = createComputePipeline(context, "radix_histogram.comp", layout_);
  scan_ = createComputePipeline(context, "radix_scan.comp", layout_);
  scatter_ = createComputePipeline(context, "radix_scatter.comp", layout_);
  bitonic_ = createComputePipeline(context, "bitonic_step.comp", layout_);
  VkBufferUsageFlags usage =
      VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  scratch_ =
      createBuffer(context, std::max<size_t>(size_t(maxCount) * 8, 8), usage, MemoryUsage::GpuOnly, "radix sort keys");
  histograms_ = createBuffer(context, size_t(std::max(blocksFor(maxCount), 1u)) * MIRAGE_RADIX_BINS * 4, usage,
                             MemoryUsage::GpuOnly, "radix sort histograms");
}

void RadixSort::cmdSort(VkCommandBuffer cmd, const Buffer& keys, uint32_t count, const RadixSortOptions& options) {
  lastDispatches_ = 0;
  if (count <= 1 || (options.digitMask & 0xFF) == 0) return;
  count = std::min(count, maxCount_);
  sio::RadixSortPush p{};
  p.histograms = histograms_.address();
  p.count = count;
  p.descending = options.descending ? 1u : 0u;
  p.blockCount = blocksFor(count);
  const Buffer* from = &keys;
  const Buffer* to = &scratch_;
  auto dispatch = [&](VkPipeline pipeline, uint32_t groups) {
    cmdComputeBarrier(cmd);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
    vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(p), &p);
    vkCmdDispatch(cmd, groups, 1, 1);
    ++lastDispatches_;
  };
  for (uint32_t digit = 0; digit < 8; ++digit) {
    if (!(options.digitMask >> digit & 1u)) continue;
    p.keysIn = from->address();
    p.keysOut = to->address();
    p.shift = 8 * digit;
    dispatch(histogram_, p.blockCount);
    dispatch(scan_, 1);
    dispatch(scatter_, p.blockCount);
    std::swap(from, to);
  }
  if (from != &keys) { // an odd number of passes leaves the result in the scratch buffer
    cmdComputeBarrier(cmd);
    VkBufferCopy region{0, 0, VkDeviceSize(count) * 8};
    vkCmdCopyBuffer(cmd, scratch_.handle(), keys.handle(), 1, &region);
  }
}

void RadixSort::cmdBitonicSort(VkCommandBuffer cmd, const Buffer& keys, uint32_t count, bool descending) {
  lastDispatches_ = 0;
  sio::RadixSortPush p{};
  p.keysIn = keys.address();
  p.count = count;
  p.descending = descending ? 1u : 0u;
  uint32_t groups = std::clamp<uint32_t>((count / 2 + 255) / 256, 1, 4096);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, bitonic_);
  for (uint32_t k = 2; k <= count; k <<= 1)
    for (uint32_t j = k >> 1; j > 0; j >>= 1) {
      cmdComputeBarrier(cmd);
      p.bitonicK = k;
      p.bitonicJ = j;
      vkCmdPushConstants(cmd, layout_, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(p), &p);
      vkCmdDispatch(cmd, groups, 1, 1);
      ++lastDispatches_;
    }
}

} // namespace mirage::gpu
