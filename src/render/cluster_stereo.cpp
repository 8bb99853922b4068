// Stereo (docs/render.md, "Stereo"): after the one selection both eyes share, each eye is
// rasterized and resolved with its own frame (packFrame: frames 1 and 2 of the slot) into its half
// of the side-by-side colour target.
#include "cluster_impl.h"
#include "mirage/gpu/commands.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

// barriers: entry as cmdRasterize's (cmdArgs(0) visible, the 64-bit buffer zeroed); on exit as
// cmdResolve's. The eyes reuse one eye-sized visibility buffer (or image + depth): the second
// eye's clear waits for the first eye's resolve to have read it.
void ClusterRenderer::Impl::cmdStereoEyes(VkCommandBuffer cmd, const sio::ClusterPush& p,
                                          const ClusterFramePlan& plan) {
  for (uint32_t e = 0; e < 2; ++e) {
    sio::ClusterPush ep = p;
    ep.frameAddress = frames[currentSlot].address() + (e + 1) * kFrameStride;
    if (e > 0) {
      constexpr VkAccessFlags2 kAll = VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT;
      cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, kAll, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, kAll);
      if (plan.bufferTarget) {
        vkCmdFillBuffer(cmd, visBuffer.handle(), 0, VK_WHOLE_SIZE, 0);
        cmdPhaseBarrier(cmd, ctx.caps().meshShader);
      }
    }
    // Each eye's raster + resolve timed as a whole too: the per-pass names repeat per eye.
    uint32_t eyeTime = timer().cmdBegin(cmd, e == 0 ? "left eye" : "right eye");
    cmdRasterize(cmd, ep, plan.backend, 0);
    cmdResolve(cmd, ep, /*firstWrite=*/e == 0);
    timer().cmdEnd(cmd, eyeTime);
  }
}

} // namespace mirage::render
