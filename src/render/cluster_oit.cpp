// Alpha BLEND: blend rasters into per-pixel fragment lists and the sorted composite (docs/render.md,
// "Alpha: MASK and BLEND").
#include "cluster_impl.h"
#include "mirage/gpu/commands.h"

#include <algorithm>

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

VkPipeline ClusterRenderer::Impl::createCompositePipeline(bool stored) {
  Unique<VkPipeline>& pipeline = stored ? compositeStoredPipeline : compositePipeline;
  if (!pipeline) {
    std::vector<uint32_t> specialization = scene.resolveSpecialization; // shading.glsl's maps (constant_id 4)
    specialization.resize(std::max<size_t>(specialization.size(), 1));
    specialization[0] = stored ? MIRAGE_OIT_COMPOSITE_STORED : 0u;
    pipeline = createComputePipeline(ctx, "cluster_oit_composite.comp", layout, specialization);
  }
  return pipeline;
}

VkPipeline ClusterRenderer::Impl::blendHardwarePipeline(bool mesh) {
  Unique<VkPipeline>& pipeline = mesh ? blendMeshPipeline : blendIndirectPipeline;
  if (!pipeline) {
    // No colour output; the opaque depth read-only, tested GREATER (reverse-Z) before the shader.
    GraphicsPipelineDesc d;
    (mesh ? d.meshShader : d.vertexShader) = mesh ? "cluster_blend.mesh" : "cluster_blend.vert";
    d.fragmentShader = mesh ? "cluster_blend_mesh.frag" : "cluster_blend.frag";
    d.layout = layout;
    d.depthFormat = kDepthFormat;
    d.depthWrite = false;
    pipeline = createGraphicsPipeline(ctx, d);
  }
  return pipeline;
}

// The opaque depth as the hardware blend raster's depth attachment, left in DEPTH_READ_ONLY_OPTIMAL
// (where the blend draw and the compute blend raster's descriptor read it). Image backends: the
// raster's depth as it is. Buffer backends: the 64-bit buffer's depth words copied in by a
// full-screen pass (cluster_blend_depth.frag; ~1 write per pixel, 0.156 ms at 1080p on the H200),
// drawn only when the hardware blend list is non-empty (ClusterCounters::blendDepthDraw) unless
// `always` (particle billboards test against it too); the compute blend raster reads the buffer
// itself, so an unwritten depth image is never read.
// barriers: on entry the opaque raster's writes visible (cmdPhaseBarrier, cmdRasterize's toRead).
void ClusterRenderer::Impl::cmdBlendDepth(VkCommandBuffer cmd, const sio::ClusterPush& p, bool bufferTarget,
                                          bool always) {
  const VkPipelineStageFlags2 kTests =
      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
  if (!bufferTarget) {
    cmdImageBarrier(cmd, {depth.handle(), kTests | kCS, VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, kTests,
                          VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT, VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL,
                          VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL, VK_IMAGE_ASPECT_DEPTH_BIT});
    return;
  }
  if (!blendDepthPipeline) {
    GraphicsPipelineDesc d;
    d.vertexShader = "cluster_fullscreen.vert";
    d.fragmentShader = "cluster_blend_depth.frag";
    d.layout = layout;
    d.depthFormat = kDepthFormat;
    d.depthCompare = VK_COMPARE_OP_ALWAYS;
    blendDepthPipeline = createGraphicsPipeline(ctx, d);
  }
  uint32_t slot = timer().cmdBegin(cmd, "blend-z");
  // Unwritten on the buffer backends (only read through descriptors): the old contents are dropped.
  cmdImageBarrier(cmd,
                  {depth.handle(), kCS, 0, kTests,
                   VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
                   VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_ASPECT_DEPTH_BIT});
  VkRenderingAttachmentInfo depthAtt{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  depthAtt.imageView = depth.view();
  depthAtt.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  depthAtt.loadOp = VK_ATTACHMENT_LOAD_OP_DONT_CARE; // every pixel written
  depthAtt.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
  ri.pDepthAttachment = &depthAtt;
  cmdBeginFullTarget(cmd, ri);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, blendDepthPipeline);
  cmdPush(cmd, p, 0);
  // Indirect: no draw when the hardware list is empty (H200, 2500 AlphaBlendModeTest copies under
  // hybrid: the unconditional copy cost 0.156 ms for a list the compute blend raster drew alone).
  if (always)
    vkCmdDraw(cmd, 3, 1, 0, 0);
  else
    vkCmdDrawIndirect(cmd, counters.handle(), offsetof(sio::ClusterCounters, blendDepthDraw), 1,
                      sizeof(VkDrawIndirectCommand));
  vkCmdEndRendering(cmd);
  cmdImageBarrier(cmd, {depth.handle(), kTests, VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, kTests | kCS,
                        VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
                        VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL,
                        VK_IMAGE_ASPECT_DEPTH_BIT});
  timer().cmdEnd(cmd, slot);
}

// Dynamic rendering over the whole target with no colour attachment and the opaque depth as a
// read-only depth attachment (DEPTH_READ_ONLY_OPTIMAL, as cmdBlendDepth leaves it): the draws that
// append to the transparency lists (the hardware blend raster, the particle billboards) test
// against it before their fragment shaders run and never write it.
void ClusterRenderer::Impl::cmdBeginOverOpaqueDepth(VkCommandBuffer cmd) {
  VkRenderingAttachmentInfo depthAtt{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  depthAtt.imageView = depth.view();
  depthAtt.imageLayout = VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL;
  depthAtt.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
  depthAtt.storeOp = VK_ATTACHMENT_STORE_OP_NONE; // read-only: nothing to store
  VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
  ri.pDepthAttachment = &depthAtt;
  cmdBeginFullTarget(cmd, ri);
}

// The hardware blend list (entries from the blend list's end) drawn with no colour output over the
// read-only opaque depth; its fragment shader appends to the transparency lists.
// barriers: the blend arguments visible; the depth prepared by cmdBlendDepth.
void ClusterRenderer::Impl::cmdHardwareBlend(VkCommandBuffer cmd, const sio::ClusterPush& p, bool mesh) {
  VkPipeline pipeline = blendHardwarePipeline(mesh);
  cmdBeginOverOpaqueDepth(cmd);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout, 0, 1, &descriptors[currentSlot].set, 0,
                          nullptr);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
  cmdDrawEyes(cmd, p, mesh, 2, MIRAGE_LIST_DOWN, MIRAGE_RASTER_BLEND_LIST + MIRAGE_LIST_DOWN);
  vkCmdEndRendering(cmd);
}

// The compute blend list (cluster_raster_blend.comp, a workgroup per cluster) and, `queue`, the
// large triangles it queued (cluster_blend_queue.comp over their tiles, sized by cluster_args.comp),
// timed as "blend-q" when `timed`.
// barriers: the blend arguments visible; the opaque depth readable (buffer, or the image backends'
// depth in DEPTH_READ_ONLY). On exit the last dispatch's appends are still to be made visible.
void ClusterRenderer::Impl::cmdComputeBlend(VkCommandBuffer cmd, const sio::ClusterPush& p, bool queue, bool timed) {
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE,
                    plans[currentSlot].stereo ? blendRasterStereoPipeline : blendRasterPipeline);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &descriptors[currentSlot].set, 0, nullptr);
  cmdPush(cmd, p, MIRAGE_RASTER_BLEND_LIST);
  vkCmdDispatchIndirect(cmd, counters.handle(), dispatchArgsOffset(2, MIRAGE_LIST_UP));
  if (!queue) return;
  uint32_t slot = timed ? timer().cmdBegin(cmd, "blend-q", kCS) : 0;
  cmdPhaseBarrier(cmd, ctx.caps().meshShader);                                // the queue complete
  cmdArgs(cmd, p, MIRAGE_BLEND_QUEUE_ARGS);                                   // its dispatch; cmdArgs leaves it visible
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, blendQueuePipeline); // the set stays bound
  cmdPush(cmd, p, MIRAGE_RASTER_BLEND_LIST);
  vkCmdDispatchIndirect(cmd, counters.handle(), offsetof(sio::ClusterCounters, blendQueueArgs));
  if (timed) timer().cmdEnd(cmd, slot, kCS);
}

// The blend lists rasterized into the transparency storage: the compute list (cmdComputeBlend) and
// the hardware list (cmdHardwareBlend), the parts timed ("blend-cs", "blend-q", "blend-hw") when
// `timed`. barriers: as cmdComputeBlend and cmdHardwareBlend (cmdBlendDepth recorded before).
void ClusterRenderer::Impl::cmdBlendRasters(VkCommandBuffer cmd, const sio::ClusterPush& p,
                                            const ClusterFramePlan& plan, bool timed) {
  BlendRaster blend = plan.blend;
  bool queue = plan.blendQueue;
  if (blend != BlendRaster::Hardware) {
    bool split = timed && (blend == BlendRaster::Hybrid || queue);
    uint32_t part = split ? timer().cmdBegin(cmd, "blend-cs", kCS) : 0;
    cmdComputeBlend(cmd, p, queue, timed);
    if (split) timer().cmdEnd(cmd, part, kCS);
  }
  if (blend != BlendRaster::Compute) {
    bool split = timed && blend == BlendRaster::Hybrid;
    uint32_t part = split ? timer().cmdBegin(cmd, "blend-hw") : 0;
    cmdHardwareBlend(cmd, p, plan.meshBlend);
    if (split) timer().cmdEnd(cmd, part);
  }
}

// The blend queue's counts, arguments and overflow, adjacent, zeroed by the ranges pass as at the frame start.
static_assert(offsetof(sio::ClusterCounters, blendQueueOverflow) + sizeof(uint32_t) -
                      offsetof(sio::ClusterCounters, blendQueueCounts) ==
                  MIRAGE_OIT_QUEUE_WORDS * sizeof(uint32_t),
              "the blend queue's counters between the rasterizations");

uint32_t ClusterRenderer::Impl::fixedSlotsFor(const ClusterFramePlan& plan) const {
  if (!plan.fixed || !oitNodes) return 0;
  return std::min<uint32_t>(MIRAGE_OIT_MAX_LAYERS, oitNodeCapacity / (colorWidth * height));
}

// Packed storage between its two rasterizations (oit_ranges.comp): every pixel's range from the
// counts of pass 1, and the blend queue emptied so pass 2 queues its large triangles afresh (the
// same fragments, whichever path draws them). After a rasterization into fixed slots
// (plan.oitFixedSlots) the pass runs only where a pixel outnumbered its slots (decided on the GPU:
// its three dispatches return at once otherwise). Timed as "oit-ranges".
// barriers: on entry pass 1's counts visible (cmdPhaseBarrier); on exit the ranges visible to pass 2.
void ClusterRenderer::Impl::cmdOitRanges(VkCommandBuffer cmd, const ClusterFramePlan& plan) {
  uint32_t slot = timer().cmdBegin(cmd, "oit-ranges", kCS);
  sio::OitRangesPush rp{};
  rp.headAddress = oitHeads.address();
  rp.keyAddress = oitNodes.address();
  rp.scratchAddress = oitRangesScratch.address();
  rp.counterAddress = counters.address() + offsetof(sio::ClusterCounters, oit);
  rp.queueAddress = plan.blendQueue ? counters.address() + offsetof(sio::ClusterCounters, blendQueueCounts) : 0;
  rp.pixels = colorWidth * height;
  rp.capacity = oitNodeCapacity;
  rp.fixedSlots = plan.oitFixedSlots;
  uint32_t blocks = (rp.pixels + MIRAGE_OIT_RANGE_BLOCK - 1) / MIRAGE_OIT_RANGE_BLOCK;
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, oitRangesPipeline);
  for (uint32_t stage = 0; stage < 3; ++stage) {
    rp.stage = stage;
    vkCmdPushConstants(cmd, oitRangesLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(rp), &rp);
    vkCmdDispatch(cmd, stage == 1 ? 1 : blocks, 1, 1);
    cmdMemoryBarrier(cmd, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCS, kStorageRW);
  }
  timer().cmdEnd(cmd, slot, kCS);
  cmdPhaseBarrier(cmd, ctx.caps().meshShader);
}

// Alpha BLEND after the resolve (scenes with BLEND materials, `blendClusters`): the blend lists
// rasterized into the transparency storage, depth-tested against the opaque depth (the compute list
// by cmdComputeBlend, the hardware list by cmdHardwareBlend), and the particle billboards appended
// to the same lists (cmdParticles); then the composite sorts and blends each pixel's fragments over
// the resolved colour. Linked lists: one rasterization ("blend"). Packed storage (plan.packed): the
// rasterization counts ("blend"), the ranges pass ("oit-ranges") places each pixel's range, a second
// rasterization writes ("blend-write"). In fixed slots (plan.oitFixedSlots) the first rasterization
// writes too, and the other two, recorded alike, idle unless a pixel outnumbered its slots. Hybrid,
// and compute with the blend queue, split "blend" into "blend-cs" (the compute list, its queue
// included), "blend-q" (the queue: its arguments and dispatch) and hybrid "blend-hw" (the hardware
// list); the buffer backends' depth copy is "blend-z".
// barriers: the resolve's colour, the opaque depth and the blend arguments (cmdArgs pass 2) written;
// the heads zeroed at the frame start. On exit the colour is in GENERAL with its writes available.
void ClusterRenderer::Impl::cmdTransparency(VkCommandBuffer cmd, sio::ClusterPush p, const ClusterFramePlan& plan,
                                            bool blendClusters, ParticleDraw* particles) {
  // Ids of the blend passes name blend-list entries (without BLEND materials the opaque list, whose
  // entry 0 the composite may load for particle lanes).
  p.visibleAddress = hasBlend() ? blendVisible.address() : visible.address();
  cmdPhaseBarrier(cmd, ctx.caps().meshShader);
  uint32_t slot = timer().cmdBegin(cmd, "blend");
  if ((blendClusters && plan.blend != BlendRaster::Compute) || plan.particles)
    cmdBlendDepth(cmd, p, plan.bufferTarget, /*always=*/plan.particles);
  if (blendClusters) cmdBlendRasters(cmd, p, plan, /*timed=*/true);
  timer().cmdEnd(cmd, slot);
  if (plan.packed && blendClusters) {
    cmdPhaseBarrier(cmd, ctx.caps().meshShader); // the counts complete
    cmdOitRanges(cmd, plan);
    slot = timer().cmdBegin(cmd, "blend-write");
    cmdBlendRasters(cmd, p, plan, /*timed=*/false);
    timer().cmdEnd(cmd, slot);
  }
  if (plan.particles) {
    // The blend rasters' appends visible to the billboards' pool-overflow walks (oit_list.glsl).
    if (blendClusters) cmdPhaseBarrier(cmd, ctx.caps().meshShader);
    cmdParticles(cmd, p, *particles);
  }
  cmdPhaseBarrier(cmd, ctx.caps().meshShader);
  slot = timer().cmdBegin(cmd, "composite", kCS);
  // Every fragment a stored colour: particles alone.
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, createCompositePipeline(/*stored=*/!blendClusters));
  cmdPush(cmd, p, MIRAGE_RASTER_BLEND_LIST); // stereo: the hardware draws left the right eye's frame pushed
  vkCmdDispatch(cmd, (colorWidth + 7) / 8, (height + 7) / 8, 1); // both eyes in stereo
  timer().cmdEnd(cmd, slot, kCS);
  if (plan.splat) cmdSplatResolve(cmd, p, *particles); // the splatted particles over the composite
}

} // namespace mirage::render
