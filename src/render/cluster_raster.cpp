// Visibility rasterizers (mesh, indirect, compute, hybrid) and the resolve (docs/render.md, "Passes").
#include "cluster_impl.h"
#include "mirage/gpu/commands.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

// Dynamic rendering over the whole target (both eyes in stereo: side by side, or `multiview`, one
// eye's size with view mask 0b11 over 2-layer attachments) with the state every cluster draw
// shares: full viewport and scissor, no culling and counter-clockwise fronts (facing is decided per
// instance in the fragment shaders: single/double-sided, mirrored, so one draw serves every material).
void ClusterRenderer::Impl::cmdBeginFullTarget(VkCommandBuffer cmd, VkRenderingInfo ri, bool multiview) {
  uint32_t w = multiview ? width : colorWidth;
  ri.renderArea = {{0, 0}, {w, height}};
  ri.layerCount = 1; // ignored with a view mask
  ri.viewMask = multiview ? 0b11u : 0u;
  vkCmdBeginRendering(cmd, &ri);
  cmdSetFullViewport(cmd, w, height);
  vkCmdSetCullMode(cmd, VK_CULL_MODE_NONE);
  vkCmdSetFrontFace(cmd, VK_FRONT_FACE_COUNTER_CLOCKWISE);
}

// The indirect draw of one list's share of a pass (ClusterListArgs): one mesh task per cluster, or
// one instance of 3 x max-triangles vertices per cluster.
void ClusterRenderer::Impl::cmdDrawList(VkCommandBuffer cmd, bool mesh, uint32_t pass, uint32_t list) {
  if (mesh)
    vkCmdDrawMeshTasksIndirectEXT(cmd, counters.handle(), dispatchArgsOffset(pass, list), 1,
                                  sizeof(VkDrawMeshTasksIndirectCommandEXT));
  else
    vkCmdDrawIndirect(cmd, counters.handle(), drawArgsOffset(pass, list), 1, sizeof(VkDrawIndirectCommand));
}

// One hardware list into the visibility image + depth (image backends; pass 1 loads pass 0's) or,
// `atomic`, into the 64-bit buffer through fragment atomics with no attachments (hybrid). Stereo
// (p: the left eye's frame): one rendering, the list drawn once per eye with that eye's frame and
// its viewport over its half of the targets, or by multiview once into the eyes' layers (the
// image backends' 2-layer targets; hybrid's fragments still address the side-by-side buffer).
// barriers: the pass's arguments visible; the images in the layouts cmdRasterize leaves them in.
void ClusterRenderer::Impl::cmdHardwareList(VkCommandBuffer cmd, const sio::ClusterPush& p, RasterBackend backend,
                                            uint32_t pass, bool atomic) {
  bool multiview = plans[currentSlot].multiview;
  VkRenderingAttachmentInfo visAtt{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  visAtt.imageView = multiview ? layeredVis.view() : vis.view();
  visAtt.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  visAtt.loadOp = pass == 0 ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD; // 0 = no cluster
  visAtt.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  VkRenderingAttachmentInfo depthAtt{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  depthAtt.imageView = multiview ? layeredDepth.view() : depth.view();
  depthAtt.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  depthAtt.loadOp = pass == 0 ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD;
  depthAtt.storeOp = VK_ATTACHMENT_STORE_OP_STORE; // the HZB reads it
  depthAtt.clearValue.depthStencil = {0.0f, 0};    // reverse-Z: far is 0
  VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
  if (!atomic) {
    ri.colorAttachmentCount = 1;
    ri.pColorAttachments = &visAtt;
    ri.pDepthAttachment = &depthAtt;
  }
  uint32_t list = atomic ? MIRAGE_LIST_DOWN : MIRAGE_LIST_UP;
  cmdBeginFullTarget(cmd, ri, multiview);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout, 0, 1, &descriptors[currentSlot].set, 0,
                          nullptr);
  bool mesh = backend == RasterBackend::Mesh;
  VkPipeline pipeline =
      mesh ? (atomic ? meshAtomicPipeline : meshPipeline) : (atomic ? indirectAtomicPipeline : indirectPipeline);
  if (!atomic && plans[currentSlot].debugView == DebugView::Overdraw) // the counting variants
    pipeline = mesh ? overdrawMeshPipeline : overdrawIndirectPipeline;
  if (multiview) pipeline = multiviewPipelines[mesh][atomic]; // ensureMultiview made it
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
  if (multiview) { // the shaders step to the right eye's frame by gl_ViewIndex
    cmdPush(cmd, p, pass * 2 + list);
    cmdDrawList(cmd, mesh, pass, list);
  } else {
    cmdDrawEyes(cmd, p, mesh, pass, list, pass * 2 + list);
  }
  vkCmdEndRendering(cmd);
}

// One list drawn within a rendering begun by cmdBeginFullTarget; stereo (p: the left eye's frame):
// once per eye with that eye's frame, viewport and scissor over its half of the target.
void ClusterRenderer::Impl::cmdDrawEyes(VkCommandBuffer cmd, const sio::ClusterPush& p, bool mesh, uint32_t pass,
                                        uint32_t list, uint32_t rasterList) {
  uint32_t eyes = plans[currentSlot].stereo ? 2 : 1;
  for (uint32_t e = 0; e < eyes; ++e) {
    sio::ClusterPush ep = p;
    ep.frameAddress += e * kFrameStride;
    if (eyes == 2) {
      VkViewport vp{float(e * width), 0.0f, float(width), float(height), 0.0f, 1.0f};
      VkRect2D scissor{{int32_t(e * width), 0}, {width, height}};
      vkCmdSetViewport(cmd, 0, 1, &vp);
      vkCmdSetScissor(cmd, 0, 1, &scissor);
    }
    cmdPush(cmd, ep, rasterList);
    cmdDrawList(cmd, mesh, pass, list);
  }
}

// barriers: cmdArgs(pass) visible; the 64-bit buffer zeroed and visible (buffer backends). On exit
// the visibility image and depth are readable by compute shaders (SHADER_READ_ONLY /
// DEPTH_READ_ONLY; the buffer backends transition them unwritten so the descriptors stay valid)
// and every write of the pass is visible to the HZB build, the next pass and the resolve.
void ClusterRenderer::Impl::cmdRasterize(VkCommandBuffer cmd, const sio::ClusterPush& p, RasterBackend backend,
                                         uint32_t pass) {
  uint32_t slot = timer().cmdBegin(cmd, pass == 0 ? "raster" : "raster2");
  bool imageTarget = backend == RasterBackend::Mesh || backend == RasterBackend::Indirect;
  const VkPipelineStageFlags2 kDepthStages =
      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
  const VkAccessFlags2 kDepthAccess =
      VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  // Pass 0 discards the images (UNDEFINED) after compute shaders last read them (the previous
  // frame's resolve; kCS, not NONE, as the source stage: write after read).
  ImageBarrier toRead[] = {{vis.handle(), kCS, 0, kCS, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                            VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL},
                           {depth.handle(), kCS, 0, kCS, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                            VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL, VK_IMAGE_ASPECT_DEPTH_BIT}};
  if (imageTarget && plans[currentSlot].multiview) {
    cmdMultiviewList(cmd, p, backend, pass);
  } else if (imageTarget) {
    // Pass 0 starts from nothing; pass 1 keeps pass 0's ids and depth (read by the HZB since).
    ImageBarrier toAttachment[] = {{vis.handle(), kCS, 0, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                                    VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                                    pass == 0 ? VK_IMAGE_LAYOUT_UNDEFINED : VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
                                    VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL},
                                   {depth.handle(), kCS, 0, kDepthStages, kDepthAccess,
                                    pass == 0 ? VK_IMAGE_LAYOUT_UNDEFINED : VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL,
                                    VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_ASPECT_DEPTH_BIT}};
    cmdImageBarriers(cmd, toAttachment);
    cmdHardwareList(cmd, p, backend, pass, /*atomic=*/false);
    toRead[0].srcStage = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
    toRead[0].srcAccess = VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT;
    toRead[0].oldLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    toRead[1].srcStage = kDepthStages;
    toRead[1].srcAccess = VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    toRead[1].oldLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    cmdImageBarriers(cmd, toRead);
  } else {
    cmdPush(cmd, p, pass * 2 + MIRAGE_LIST_UP);
    bool stereo = plans[currentSlot].stereo; // p: the left eye's frame, both eyes per workgroup
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, stereo ? rasterStereoPipeline : rasterPipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &descriptors[currentSlot].set, 0,
                            nullptr);
    vkCmdDispatchIndirect(cmd, counters.handle(), dispatchArgsOffset(pass, MIRAGE_LIST_UP));
    if (rasterMaskPipeline) { // masked clusters of the same list (the opaque kernel skipped them)
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, stereo ? rasterMaskStereoPipeline : rasterMaskPipeline);
      vkCmdDispatchIndirect(cmd, counters.handle(), dispatchArgsOffset(pass, MIRAGE_LIST_UP));
    }
    // The lean list (small unclipped clusters, the per-thread walk alone), with no barrier after
    // the kernels above: they all only take 64-bit atomic maxima of the buffer.
    if (plans[currentSlot].lean) {
      cmdPush(cmd, p, pass * 2 + MIRAGE_LIST_DOWN);
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, stereo ? rasterLeanStereoPipeline : rasterLeanPipeline);
      vkCmdDispatchIndirect(cmd, counters.handle(), dispatchArgsOffset(pass, MIRAGE_LIST_DOWN));
    }
    if (backend == RasterBackend::Hybrid)
      cmdHardwareList(cmd, p, hybridListMesh() ? RasterBackend::Mesh : RasterBackend::Indirect, pass,
                      /*atomic=*/true);
    // Unwritten, but the descriptors must be valid: once per image (every path leaves them so).
    if (pass == 0 && !visImagesDefined) cmdImageBarriers(cmd, toRead);
  }
  visImagesDefined = true;
  cmdPhaseBarrier(cmd, ctx.caps().meshShader);
  timer().cmdEnd(cmd, slot);
}

// Stereo by multiview, image backends: the list into the eyes' layers (pass 1 loads pass 0's, which
// the layers still hold), then each layer copied into its half of the side-by-side visibility image
// and depth. The copy keeps every reader (HZB, resolve, debug views, blend rasters) on the one
// side-by-side layout the compute raster writes too; it moves 8 bytes per pixel each pass, 12 when
// the depth is read after the raster (the HZB with occlusion, the blend rasters' depth test).
// barriers: as cmdRasterize's image branch; on exit the same layouts, the copies visible to compute
// shaders and to depth tests (the hardware blend raster); an uncopied depth is left unwritten.
void ClusterRenderer::Impl::cmdMultiviewList(VkCommandBuffer cmd, const sio::ClusterPush& p, RasterBackend backend,
                                             uint32_t pass) {
  const VkPipelineStageFlags2 kDepthStages =
      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
  const VkAccessFlags2 kDepthAccess =
      VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  const VkPipelineStageFlags2 kColorStage = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
  const VkPipelineStageFlags2 kCopy = VK_PIPELINE_STAGE_2_COPY_BIT;
  // Pass 0 starts from nothing (the last copy read the layers: write after read); pass 1 keeps pass 0's.
  VkImageLayout layerOld = pass == 0 ? VK_IMAGE_LAYOUT_UNDEFINED : VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
  ImageBarrier toAttachment[] = {{layeredVis.handle(), kCopy, 0, kColorStage,
                                  VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                                  layerOld, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL},
                                 {layeredDepth.handle(), kCopy, 0, kDepthStages, kDepthAccess, layerOld,
                                  VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_ASPECT_DEPTH_BIT}};
  cmdImageBarriers(cmd, toAttachment);
  cmdHardwareList(cmd, p, backend, pass, /*atomic=*/false);
  const ClusterFramePlan& plan = plans[currentSlot]; // the depth's readers (stereo runs blend passes by hasBlend)
  bool copyDepth = plan.occlusion || hasBlend() || plan.particles;
  // The side-by-side images are overwritten whole: their contents (read by compute shaders: the
  // HZB, or the previous frame's resolve) are dropped.
  ImageBarrier toCopy[] = {{layeredVis.handle(), kColorStage, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, kCopy,
                            VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                            VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL},
                           {layeredDepth.handle(), kDepthStages, VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, kCopy,
                            VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
                            VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_IMAGE_ASPECT_DEPTH_BIT},
                           {vis.handle(), kCS, 0, kCopy, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                            VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL},
                           {depth.handle(), kCS, 0, kCopy, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                            VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_ASPECT_DEPTH_BIT}};
  cmdImageBarriers(cmd, toCopy);
  uint32_t slot = timer().cmdBegin(cmd, "layer-copy");
  for (VkImageAspectFlags aspect : {VK_IMAGE_ASPECT_COLOR_BIT, VK_IMAGE_ASPECT_DEPTH_BIT}) {
    if (aspect == VK_IMAGE_ASPECT_DEPTH_BIT && !copyDepth) continue;
    VkImageCopy regions[2];
    for (uint32_t e = 0; e < 2; ++e) {
      regions[e] = {};
      regions[e].srcSubresource = {aspect, 0, e, 1};
      regions[e].dstSubresource = {aspect, 0, 0, 1};
      regions[e].dstOffset = {int32_t(e * width), 0, 0};
      regions[e].extent = {width, height, 1};
    }
    bool ids = aspect == VK_IMAGE_ASPECT_COLOR_BIT;
    vkCmdCopyImage(cmd, ids ? layeredVis.handle() : layeredDepth.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                   ids ? vis.handle() : depth.handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 2, regions);
  }
  timer().cmdEnd(cmd, slot);
  ImageBarrier toRead[] = {
      {vis.handle(), kCopy, VK_ACCESS_2_TRANSFER_WRITE_BIT, kCS, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL},
      {depth.handle(), kCopy, copyDepth ? VK_ACCESS_2_TRANSFER_WRITE_BIT : 0, kCS | kDepthStages,
       VK_ACCESS_2_SHADER_SAMPLED_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT,
       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL, VK_IMAGE_ASPECT_DEPTH_BIT}};
  cmdImageBarriers(cmd, toRead);
}

// barriers: cmdRasterize's output visible to compute shaders. The color target ends in GENERAL with
// the resolve's writes available, which the readback expects; its old contents are discarded.
// Stereo (p: the left eye's frame): one dispatch over both halves.
void ClusterRenderer::Impl::cmdResolve(VkCommandBuffer cmd, const sio::ClusterPush& p) {
  uint32_t slot = timer().cmdBegin(cmd, "resolve");
  cmdImageBarrier(cmd, {color.handle(), VK_PIPELINE_STAGE_2_NONE, 0, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                        VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL});
  bool debug = plans[currentSlot].debugView != DebugView::None; // cluster_debug_resolve.comp instead
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, debug ? debugResolvePipeline : resolvePipeline);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &descriptors[currentSlot].set, 0, nullptr);
  cmdPush(cmd, p, 0);
  uint32_t tileRows = debug ? 1 : MIRAGE_RESOLVE_TILE_ROWS; // 8x8 pixel tiles per workgroup
  vkCmdDispatch(cmd, (colorWidth + 7) / 8, (height + 8 * tileRows - 1) / (8 * tileRows), 1);
  timer().cmdEnd(cmd, slot);
}

} // namespace mirage::render
