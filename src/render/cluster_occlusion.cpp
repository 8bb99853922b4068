// Two-pass occlusion culling: the HZB of pass 1 and the pass-2 cull of candidates and late instances
// against it (docs/render.md, "Culling").
#include "cluster_impl.h"
#include "mirage/gpu/commands.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

// barriers: the raster pass's depth visible to compute (cmdRasterize). On exit every HZB level is
// written and visible.
void ClusterRenderer::Impl::cmdBuildHzb(VkCommandBuffer cmd, const sio::ClusterPush& p) {
  uint32_t slot = timer().cmdBegin(cmd, "hzb", kCS);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, hzbPipeline);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &descriptors[currentSlot].set, 0, nullptr);
  // Levels 1..5 per 16x16 tile of level 1, then one workgroup for the rest (cluster_hzb.comp).
  uint32_t w1 = (colorWidth + 1) / 2, h1 = (height + 1) / 2; // both eyes in stereo
  cmdPush(cmd, p, 0);
  vkCmdDispatch(cmd, (w1 + 15) / 16, (h1 + 15) / 16, 1);
  if (hzbLevels > 6) {
    cmdMemoryBarrier(cmd, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCS,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
    cmdPush(cmd, p, 1);
    vkCmdDispatch(cmd, 1, 1, 1);
  }
  cmdMemoryBarrier(cmd, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCS,
                   VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
  timer().cmdEnd(cmd, slot, kCS);
}

// Pass-2 culling against the HZB of pass 1: late instances (then the phase-2 selection of the ones
// that pass) and the clusters left over from phase 1.
// barriers: the HZB, the late instances and the candidates visible; on exit pass 2's appends are.
void ClusterRenderer::Impl::cmdOcclusion(VkCommandBuffer cmd, const sio::ClusterPush& p, bool hierarchy) {
  uint32_t slot = timer().cmdBegin(cmd, "occlusion", kCS);
  cmdPush(cmd, p, 0);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, occlusionPipeline);
  vkCmdDispatchIndirect(cmd, counters.handle(), offsetof(sio::ClusterCounters, occlusionArgs));
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, instanceOcclusionPipeline);
  vkCmdDispatchIndirect(cmd, counters.handle(), offsetof(sio::ClusterCounters, instanceOcclusionArgs));
  cmdPhaseBarrier(cmd, ctx.caps().meshShader);
  if (hierarchy) {
    cmdTraverse(cmd, p, /*phase=*/1);
  } else {
    cmdPush(cmd, p, /*phase=*/1);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, selectPipeline);
    vkCmdDispatchIndirect(cmd, counters.handle(), offsetof(sio::ClusterCounters, lateSelectArgs));
  }
  cmdPhaseBarrier(cmd, ctx.caps().meshShader);
  timer().cmdEnd(cmd, slot, kCS);
}

} // namespace mirage::render
