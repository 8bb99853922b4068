// Cluster selection: instance cull, then LOCALCUT + frustum + cones by the flat pass or the LOD BVH
// / DAG traversal (docs/render.md, "Selection"), and the raster arguments of each pass.
#include "cluster_impl.h"
#include "mirage/gpu/commands.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

// barriers: on entry the counters were zeroed and the clears made visible (cmdPhaseBarrier); on
// exit the visible instances, pass-1 lists and occlusion candidates are written and visible, and
// the 64-bit visibility buffer (buffer backends) is zeroed.
void ClusterRenderer::Impl::cmdSelect(VkCommandBuffer cmd, const sio::ClusterPush& p, bool hierarchy) {
  cmdPush(cmd, p, 0);
  // Per-instance culling first: the cluster pass only visits clusters of visible instances.
  uint32_t slot = timer().cmdBegin(cmd, "cull", kCS);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, cullPipeline);
  vkCmdDispatch(cmd, (scene.instanceCount + MIRAGE_CLUSTER_WORKGROUP - 1) / MIRAGE_CLUSTER_WORKGROUP, 1, 1);
  // The 64-bit visibility buffer is zeroed here, with no barrier between it and the cull dispatch,
  // so the two overlap (the frame's opening barrier ordered it after the last frame's readers; the
  // barrier below before the raster writes it). H100: 2500 blobs frame 0.183 -> 0.179 ms, stereo
  // 0.311 -> 0.304 against a fill before the cull's barrier.
  // Skipped when the last frame's resolve left it zero (MIRAGE_FRAME_CLEAR_VIS).
  if (plans[currentSlot].bufferTarget && !visBufferZero) vkCmdFillBuffer(cmd, visBuffer.handle(), 0, VK_WHOLE_SIZE, 0);
  visBufferZero = plans[currentSlot].clearsVisibility();
  timer().cmdEnd(cmd, slot, kCS);
  cmdPhaseBarrier(cmd, ctx.caps().meshShader);
  // LOCALCUT + frustum + cones: a flat pass over every (visible instance, cluster of its level
  // range), or the BVH traversal that visits only groups above the cut.
  slot = timer().cmdBegin(cmd, "select", kCS);
  if (hierarchy) {
    cmdTraverse(cmd, p, 0);
  } else {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, selectPipeline);
    vkCmdDispatchIndirect(cmd, counters.handle(), offsetof(sio::ClusterCounters, selectArgs));
  }
  timer().cmdEnd(cmd, slot, kCS);
  cmdPhaseBarrier(cmd, ctx.caps().meshShader);
}

// Hierarchical selection of one phase: one dispatch per BVH depth over the nodes queued by the
// previous depth (depth 0: the level roots queued by the cull pass or the late-instance test),
// as many as the deepest BVH needs, fixed per scene (cluster_traverse.comp).
// barriers: entry as the flat pass's dispatch; on exit the last depth's appends are still to be
// made visible by the caller.
void ClusterRenderer::Impl::cmdTraverse(VkCommandBuffer cmd, const sio::ClusterPush& p, uint32_t phase) {
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, traversePipeline);
  for (uint32_t bvhDepth = 0; bvhDepth <= traversalDepth; ++bvhDepth) {
    if (bvhDepth > 0) cmdPhaseBarrier(cmd, ctx.caps().meshShader);
    cmdPush(cmd, p, phase | bvhDepth << 1);
    vkCmdDispatchIndirect(cmd, traversal.handle(),
                          offsetof(sio::ClusterTraversal, args) + (phase * MIRAGE_LOD_MAX_DEPTH + bvhDepth) * 16);
  }
}

// barriers: the lists' appends visible (cmdPhaseBarrier); on exit the pass's arguments are.
void ClusterRenderer::Impl::cmdArgs(VkCommandBuffer cmd, const sio::ClusterPush& p, uint32_t pass) {
  cmdPush(cmd, p, pass);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, argsPipeline);
  vkCmdDispatch(cmd, 1, 1, 1);
  cmdPhaseBarrier(cmd, ctx.caps().meshShader);
}

} // namespace mirage::render
