// Sorted mode of the particle billboards (render/particle_draw.h, docs/particles.md "Rendering"):
// the reference order. Every live record gets a key (view-depth order << 32 | global index), the
// keys are radix-sorted on the GPU (back to front), and each sorted particle finds its gap among
// the blended triangles the forward renderer sorted on the CPU by the same view depth; each gap's
// particles are one run of the sorted keys, drawn by one indirect draw between the triangles.
#include <algorithm>

#include "mirage/gpu/commands.h"
#include "particle_draw_impl.h"
#include "render_util.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

// barriers: cmdPrepare's arguments and batch table visible to compute shaders; the records written.
void ParticleDraw::cmdSort(VkCommandBuffer cmd, const glm::mat4& view, VkDeviceAddress triangleDepths,
                           uint32_t triangleCount, const gpu::Buffer& gapDraws) {
  Impl& d = *impl_;
  if (d.batches.empty()) return;
  d.ensureComputeLayout();
  if (!d.sortKeysPipeline) {
    d.sortKeysPipeline = createComputePipeline(d.ctx, "particle_sort_keys.comp", d.computeLayout);
    d.sortGapsPipeline = createComputePipeline(d.ctx, "particle_sort_gaps.comp", d.computeLayout);
  }
  uint32_t total = std::max(d.totalRecords, 1u);
  // The keys and the sort's scratch follow the batches' room (grown only here: the batches change
  // with no frame in flight that draws them).
  if (!d.radix || d.radix->maxCount() < total) {
    d.radix = std::make_unique<RadixSort>(d.ctx, total);
    d.sortKeys = createBuffer(d.ctx, uint64_t(total) * 8,
                              VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT |
                                  VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                              MemoryUsage::GpuOnly, "particle sort keys");
  }
  sio::ParticleSortPush push{};
  push.view = view;
  push.batchAddress = d.batchTable.address();
  push.argsAddress = d.indirect.address();
  push.keyAddress = d.sortKeys.address();
  push.depthAddress = triangleDepths;
  push.gapAddress = gapDraws.address();
  push.total = d.totalRecords;
  push.batchCount = uint32_t(d.batches.size());
  push.triangleCount = triangleCount;
  vkCmdFillBuffer(cmd, gapDraws.handle(), 0, VK_WHOLE_SIZE, 0); // every gap empty until a run claims it
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.sortKeysPipeline);
  vkCmdPushConstants(cmd, d.computeLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
  d.cmdDispatchRecords(cmd);
  // RadixSort::cmdSort waits for the keys (earlier compute writes) itself.
  RadixSortOptions options;
  options.digitMask = digitMaskForIndexBelow(total);
  d.radix->cmdSort(cmd, d.sortKeys, d.totalRecords, options);
  cmdMemoryBarrier(cmd, kCS | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                   VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT, kCS, kStorageRW);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.sortGapsPipeline);
  vkCmdPushConstants(cmd, d.computeLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
  d.cmdDispatchRecords(cmd);
  cmdMemoryBarrier(cmd, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT,
                   VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
}

void ParticleDraw::cmdDrawGap(VkCommandBuffer cmd, VkDeviceAddress frame, const gpu::Buffer& gapDraws, uint32_t gap) {
  Impl& d = *impl_;
  if (d.batches.empty() || !d.sortKeys) return;
  d.cmdBindDraw(cmd, OitMode::Sorted);
  sio::ParticleDrawPush push = d.drawPush(frame, 0);
  push.recordAddress = d.sortKeys.address();
  push.mode = MIRAGE_PARTICLE_DRAW_KEYS;
  vkCmdPushConstants(cmd, d.layout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(push), &push);
  vkCmdDrawIndirect(cmd, gapDraws.handle(), gap * sizeof(VkDrawIndirectCommand), 1, sizeof(VkDrawIndirectCommand));
}

} // namespace mirage::render
