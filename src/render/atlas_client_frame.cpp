// The thin client's frame (docs/stream.md, "The client's renderer"): the queued patch records and atlas texels
// uploaded through the slot's staging buffer, opaque and MASK patches with depth, BLEND patches and
// particle billboards appended to per-pixel linked lists and resolved over the opaque colour by the
// forward renderer's resolve (forward_oit_resolve.comp, oit_list.glsl).
#include <algorithm>
#include <cstring>

#include <fmt/format.h>

#include "atlas_client_impl.h"
#include "mirage/gpu/commands.h"
#include "render_util.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

namespace {

constexpr VkPipelineStageFlags2 kFS = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
constexpr VkPipelineStageFlags2 kTransfer = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT;
constexpr VkPipelineStageFlags2 kTests =
    VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
constexpr VkPipelineStageFlags2 kColorOut = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
constexpr uint32_t kOpaqueModes = 1u << MIRAGE_ALPHA_OPAQUE | 1u << MIRAGE_ALPHA_MASK;
constexpr uint32_t kBlendModes = 1u << MIRAGE_ALPHA_BLEND;

Status checkSettings(const AtlasClientSettings& s) {
  if (s.width == 0 || s.height == 0 || s.width > kMaxRenderDimension || s.height > kMaxRenderDimension)
    return Error{fmt::format("render size {}x{} is outside 1..{}", s.width, s.height, kMaxRenderDimension)};
  if (s.oitNodesPerPixel < 1 || s.oitNodesPerPixel > 64)
    return Error{fmt::format("OIT node pool of {} nodes per pixel is outside 1..64", s.oitNodesPerPixel)};
  return Ok{};
}

} // namespace

// New targets when the size changes and a pool when the size or nodes per pixel do; frames in
// flight keep the old ones until they completed.
void AtlasClientRenderer::Impl::ensureTargets(uint32_t w, uint32_t h, uint32_t nodesPerPixel) {
  if (w != width || h != height) {
    retired.retire(std::move(color), inFlight());
    retired.retire(std::move(depth), inFlight());
    color = createImage2D(
        ctx, w, h, kClientColorFormat,
        VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_STORAGE_BIT, "color");
    depth = createImage2D(ctx, w, h, kClientDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, "depth");
    width = w;
    height = h;
    oitNodesPerPixel = 0; // the pool follows the size
  }
  if (!transparent() || (oitHeads && oitNodesPerPixel == nodesPerPixel)) return;
  retired.retire(std::move(oitHeads), inFlight());
  retired.retire(std::move(oitNodes), inFlight());
  retired.retire(std::move(oitColors), inFlight());
  uint64_t pixels = uint64_t(w) * h;
  oitHeads = createBuffer(ctx, pixels * sizeof(sio::OitPixelHead),
                          VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::GpuOnly,
                          "oit heads");
  oitNodeCapacity = uint32_t(std::min<uint64_t>(
      {pixels * nodesPerPixel, ctx.caps().maxStorageBufferRange / sizeof(sio::OitNode), uint64_t(UINT32_MAX) - 1}));
  oitNodes = createBuffer(ctx, uint64_t(oitNodeCapacity) * sizeof(sio::OitNode),
                          VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::GpuOnly,
                          "oit nodes");
  oitNodesUnzeroed = true;
  oitColors = createBuffer(ctx, uint64_t(oitNodeCapacity) * 8, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::GpuOnly,
                           "oit colours");
  oitNodesPerPixel = nodesPerPixel;
}

void AtlasClientRenderer::Impl::cmdUpload(VkCommandBuffer cmd, uint32_t slot) {
  const bool atlasWrites = !atlasDefined || !pendingRegions.empty();
  if (dirty.empty() && !atlasWrites) return;
  // The staging layout: patch records first, then the texels (16-byte aligned: a texel copy's
  // offset must be a multiple of the texel size).
  const uint64_t patchBytes = dirty.size() * sizeof(sio::GpuClientPatch);
  const uint64_t texelBase = (patchBytes + 15) & ~uint64_t(15);
  const uint64_t needed = std::max<uint64_t>(texelBase + pendingTexels.size(), 16);
  // The slot's previous frame completed (record's contract), so its staging may be replaced now.
  if (staging[slot].size() < needed)
    staging[slot] = createBuffer(ctx, std::max<uint64_t>(needed, staging[slot].size() * 2),
                                 VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUsage::Upload, "client staging");
  uint8_t* out = staging[slot].mapped();

  if (!dirty.empty()) {
    // Runs of consecutive slots, one copy each.
    std::sort(dirty.begin(), dirty.end());
    std::vector<VkBufferCopy> copies;
    for (size_t k = 0; k < dirty.size(); ++k) {
      uint32_t s = dirty[k];
      std::memcpy(out + k * sizeof(sio::GpuClientPatch), &slots[s], sizeof(sio::GpuClientPatch));
      dirtyFlag[s] = 0;
      if (k > 0 && dirty[k - 1] + 1 == s)
        copies.back().size += sizeof(sio::GpuClientPatch);
      else
        copies.push_back(
            {k * sizeof(sio::GpuClientPatch), s * sizeof(sio::GpuClientPatch), sizeof(sio::GpuClientPatch)});
    }
    vkCmdCopyBuffer(cmd, staging[slot].handle(), patches.handle(), uint32_t(copies.size()), copies.data());
    dirty.clear();
  }

  if (atlasWrites) {
    // Earlier frames' sampling is ordered by the frame's first barrier (ALL_COMMANDS).
    cmdImageBarrier(cmd,
                    {atlas.handle(), VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, 0, kTransfer, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     atlasDefined ? VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL : VK_IMAGE_LAYOUT_UNDEFINED,
                     VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL});
    if (!atlasDefined) { // black until the server's first atlas arrives
      VkClearColorValue black{{0.0f, 0.0f, 0.0f, 1.0f}};
      VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
      vkCmdClearColorImage(cmd, atlas.handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &black, 1, &range);
      if (!pendingRegions.empty()) // the copies below write after the clear
        cmdMemoryBarrier(cmd, kTransfer, VK_ACCESS_2_TRANSFER_WRITE_BIT, kTransfer, VK_ACCESS_2_TRANSFER_WRITE_BIT);
      atlasDefined = true;
    }
    if (!pendingRegions.empty()) {
      std::memcpy(out + texelBase, pendingTexels.data(), pendingTexels.size());
      std::vector<VkBufferImageCopy> copies;
      copies.reserve(pendingRegions.size());
      for (const PendingAtlasRegion& r : pendingRegions) {
        VkBufferImageCopy c{};
        c.bufferOffset = texelBase + r.offset;
        c.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
        c.imageOffset = {int32_t(r.x), int32_t(r.y), 0};
        c.imageExtent = {r.width, r.height, 1};
        copies.push_back(c);
      }
      // Regions in the order queued, a later region's texels over an earlier one's: the regions of
      // one copy command must not overlap, so a region overlapping one before it starts a new
      // command after a barrier.
      size_t begin = 0;
      for (size_t k = 1; k <= copies.size(); ++k) {
        bool overlaps = false;
        if (k < copies.size())
          for (size_t j = begin; j < k && !overlaps; ++j) {
            const PendingAtlasRegion &a = pendingRegions[j], &b = pendingRegions[k];
            overlaps = a.x < b.x + b.width && b.x < a.x + a.width && a.y < b.y + b.height && b.y < a.y + a.height;
          }
        if (k < copies.size() && !overlaps) continue;
        vkCmdCopyBufferToImage(cmd, staging[slot].handle(), atlas.handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                               uint32_t(k - begin), copies.data() + begin);
        if (k < copies.size())
          cmdMemoryBarrier(cmd, kTransfer, VK_ACCESS_2_TRANSFER_WRITE_BIT, kTransfer, VK_ACCESS_2_TRANSFER_WRITE_BIT);
        begin = k;
      }
      pendingRegions.clear();
      pendingTexels.clear();
    }
    cmdImageBarrier(cmd, {atlas.handle(), kTransfer, VK_ACCESS_2_TRANSFER_WRITE_BIT, kFS,
                          VK_ACCESS_2_SHADER_SAMPLED_READ_BIT, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                          VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL});
  }
  // The patch records to the vertex shaders.
  cmdMemoryBarrier(cmd, kTransfer, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT,
                   VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
}

void AtlasClientRenderer::Impl::cmdBindDraw(VkCommandBuffer cmd, VkDeviceAddress frame, VkDeviceAddress records,
                                            uint32_t alphaModes, VkDeviceAddress oit) {
  sio::AtlasClientPush push{};
  push.frameAddress = frame;
  push.patchAddress = records;
  push.oitAddress = oit;
  push.atlasSize = glm::vec2(float(config.atlasWidth), float(config.atlasHeight));
  push.alphaModes = alphaModes;
  vkCmdPushConstants(cmd, layout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(push), &push);
  // Both faces: the server's visibility decided what is sent, and a patch seen from behind shows
  // the colour it was shaded with.
  vkCmdSetCullMode(cmd, VK_CULL_MODE_NONE);
  vkCmdSetFrontFace(cmd, VK_FRONT_FACE_COUNTER_CLOCKWISE);
  cmdSetFullViewport(cmd, width, height);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout, 0, 1, &atlasDescriptors.set, 0, nullptr);
}

// After the opaque pass (colour and depth in attachment layouts, depth stored): BLEND patches and
// particles into the lists, resolved over the colour in place; the colour ends in GENERAL either way.
void AtlasClientRenderer::Impl::cmdTransparency(VkCommandBuffer cmd, uint32_t slot, VkDeviceAddress frame,
                                                FrameStats& stats) {
  auto colorToGeneral = [&] {
    cmdImageBarrier(cmd, {color.handle(), kColorOut, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, kCS | kTransfer,
                          kStorageRW | VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                          VK_IMAGE_LAYOUT_GENERAL});
  };
  GpuTimer& timer = timers[slot];
  if (!slotOit[slot]) {
    timer.cmdEnd(cmd, timer.cmdBegin(cmd, "blend")); // reported every frame, 0 ms without BLEND patches
    return colorToGeneral();
  }
  cmdImageBarrier(cmd, {depth.handle(), kTests, VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, kTests,
                        VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL,
                        VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_ASPECT_DEPTH_BIT});
  VkRenderingAttachmentInfo depthAtt{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  depthAtt.imageView = depth.view();
  depthAtt.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  depthAtt.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
  depthAtt.storeOp = VK_ATTACHMENT_STORE_OP_NONE; // nothing written
  VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
  ri.renderArea = {{0, 0}, {width, height}};
  ri.layerCount = 1;
  ri.pDepthAttachment = &depthAtt;
  uint32_t blendTime = timer.cmdBegin(cmd, "blend");
  vkCmdBeginRendering(cmd, &ri);
  if (blendPatches != 0) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, appendPipeline);
    cmdBindDraw(cmd, frame, patches.address(), kBlendModes, oitLists[slot].address());
    vkCmdDraw(cmd, uint32_t(slots.size()) * MIRAGE_CLIENT_SLOT_VERTICES, 1, 0, 0);
    stats.drawCalls++;
  }
  if (!particles.empty()) { // one instance per particle, six vertices (two triangles) each
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, particlePipeline);
    cmdBindDraw(cmd, frame, particleRecords[slot].address(), 0, oitLists[slot].address());
    vkCmdDraw(cmd, 6, uint32_t(particles.size()), 0, 0);
    stats.drawCalls++;
  }
  vkCmdEndRendering(cmd);
  timer.cmdEnd(cmd, blendTime);
  colorToGeneral();

  cmdMemoryBarrier(cmd, kFS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCS, kStorageRW); // the resolve zeroes the nodes
  // The slot's set: its frame is the only one recorded with it, and its previous one completed.
  VkDescriptorImageInfo target{VK_NULL_HANDLE, color.view(), VK_IMAGE_LAYOUT_GENERAL};
  writeImageDescriptors(ctx, resolveDescriptors[slot].set, 0, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, {&target, 1});
  uint32_t resolveTime = timer.cmdBegin(cmd, "composite", kCS);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, resolvePipeline);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, resolveLayout, 0, 1, &resolveDescriptors[slot].set, 0,
                          nullptr);
  sio::ForwardResolvePush push{oitLists[slot].address(), width, height};
  vkCmdPushConstants(cmd, resolveLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
  vkCmdDispatch(cmd, (width + 7) / 8, (height + 7) / 8, 1);
  timer.cmdEnd(cmd, resolveTime, kCS);
  // The colour's writes visible to compute and transfers (colorTarget()); the counters to readback.
  cmdMemoryBarrier(cmd, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCS | kTransfer,
                   kStorageRW | VK_ACCESS_2_TRANSFER_READ_BIT);
  VkBufferCopy copy{0, 0, sizeof(sio::OitCounters)};
  vkCmdCopyBuffer(cmd, oitCounters.handle(), oitReadback[slot].handle(), 1, &copy);
  cmdMemoryBarrier(cmd, kTransfer, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                   VK_ACCESS_2_HOST_READ_BIT);
}

Status AtlasClientRenderer::record(VkCommandBuffer cmd, const AtlasClientSettings& s, uint32_t slot) {
  if (slot >= kMaxFramesInFlight)
    return Error{fmt::format("frame slot {} is outside 0..{}", slot, kMaxFramesInFlight - 1)};
  if (Status st = checkSettings(s); !st) return st.error();
  Impl& d = *impl_;
  d.retired.completed(slot); // a slot is recorded again only after its previous frame completed
  d.recorded[slot] = false;
  d.ensureTargets(s.width, s.height, s.oitNodesPerPixel);
  sio::ViewFrame view = viewFrame(withClipPlanes(s.camera, d.bounds), s.width, s.height);
  std::memcpy(d.frames[slot].mapped(), &view, sizeof(view));
  const VkDeviceAddress frame = d.frames[slot].address();

  FrameStats& stats = d.slotStats[slot];
  stats = {};
  stats.trianglesSubmitted = d.patchTriangles;
  GpuTimer& timer = d.timers[slot];
  timer.cmdReset(cmd);
  // The first barrier orders this frame after all work submitted before it: the targets, lists,
  // patch buffer and atlas are shared by the slots.
  cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                   VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                   VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
  uint32_t frameTime = timer.cmdBegin(cmd, "frame");
  uint32_t uploadTime = timer.cmdBegin(cmd, "upload");
  d.cmdUpload(cmd, slot);
  timer.cmdEnd(cmd, uploadTime);

  d.slotOit[slot] = d.transparent();
  if (!d.particles.empty()) { // the slot's previous frame completed: its records may be replaced
    uint64_t bytes = d.particles.size() * sizeof(sio::GpuClientParticle);
    if (d.particleRecords[slot].size() < bytes)
      d.particleRecords[slot] =
          createBuffer(d.ctx, std::max<uint64_t>(bytes, d.particleRecords[slot].size() * 2),
                       VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::Upload, "client particles");
    std::memcpy(d.particleRecords[slot].mapped(), d.particles.data(), bytes);
  }
  if (d.slotOit[slot]) {
    sio::OitLists l{d.oitHeads.address(),
                    d.oitNodes.address(),
                    d.oitColors.address(),
                    d.oitCounters.address(),
                    d.width,
                    d.height,
                    d.oitNodeCapacity,
                    0};
    std::memcpy(d.oitLists[slot].mapped(), &l, sizeof(l));
    vkCmdFillBuffer(cmd, d.oitHeads.handle(), 0, VK_WHOLE_SIZE, 0); // empty lists
    vkCmdFillBuffer(cmd, d.oitCounters.handle(), 0, VK_WHOLE_SIZE, 0);
    if (d.oitNodesUnzeroed) { // a new pool; afterwards the resolve leaves it zero (oit_list.glsl)
      vkCmdFillBuffer(cmd, d.oitNodes.handle(), 0, VK_WHOLE_SIZE, 0);
      d.oitNodesUnzeroed = false;
    }
    cmdMemoryBarrier(cmd, kTransfer, VK_ACCESS_2_TRANSFER_WRITE_BIT, kFS | kCS, kStorageRW);
  }

  ImageBarrier toAttachment[] = {
      {d.color.handle(), VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, 0, kColorOut, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
       VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL},
      {d.depth.handle(), VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, 0, kTests,
       VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
       VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_ASPECT_DEPTH_BIT}};
  cmdImageBarriers(cmd, toAttachment);
  VkRenderingAttachmentInfo colorAtt{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  colorAtt.imageView = d.color.view();
  colorAtt.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  colorAtt.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  colorAtt.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  colorAtt.clearValue.color = {{s.background.r, s.background.g, s.background.b, s.background.a}};
  VkRenderingAttachmentInfo depthAtt{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  depthAtt.imageView = d.depth.view();
  depthAtt.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  depthAtt.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  depthAtt.storeOp = VK_ATTACHMENT_STORE_OP_STORE; // the blend pass tests against it
  depthAtt.clearValue.depthStencil = {0.0f, 0};    // reverse-Z: far is 0
  VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
  ri.renderArea = {{0, 0}, {d.width, d.height}};
  ri.layerCount = 1;
  ri.colorAttachmentCount = 1;
  ri.pColorAttachments = &colorAtt;
  ri.pDepthAttachment = &depthAtt;
  uint32_t opaqueTime = timer.cmdBegin(cmd, "opaque");
  vkCmdBeginRendering(cmd, &ri);
  if (!d.slots.empty()) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, d.opaquePipeline);
    d.cmdBindDraw(cmd, frame, d.patches.address(), kOpaqueModes, 0);
    vkCmdDraw(cmd, uint32_t(d.slots.size()) * MIRAGE_CLIENT_SLOT_VERTICES, 1, 0, 0);
    stats.drawCalls++;
  }
  vkCmdEndRendering(cmd);
  timer.cmdEnd(cmd, opaqueTime);
  d.cmdTransparency(cmd, slot, frame, stats);
  timer.cmdEnd(cmd, frameTime);
  d.recorded[slot] = true;
  return Ok{};
}

Result<RenderOutput> AtlasClientRenderer::collect(uint32_t slot) {
  Impl& d = *impl_;
  if (slot >= kMaxFramesInFlight || !d.recorded[slot])
    return Error{fmt::format("frame slot {} holds no recorded frame", slot)};
  RenderOutput out;
  out.stats = d.slotStats[slot];
  out.stats.passTimes = d.timers[slot].read();
  if (d.slotOit[slot])
    out.stats.oit =
        oitStats(*reinterpret_cast<const sio::OitCounters*>(d.oitReadback[slot].mapped()), d.oitNodeCapacity);
  d.recorded[slot] = false;
  d.retired.completed(slot);
  return out;
}

const gpu::Image& AtlasClientRenderer::colorTarget() const { return impl_->color; }

Result<RenderOutput> AtlasClientRenderer::render(const AtlasClientSettings& s) {
  Impl& d = *impl_;
  if (Status st = checkSettings(s); !st) return st.error(); // nothing submitted
  Status recorded = Ok{};
  d.ctx.submitAndWait([&](VkCommandBuffer cmd) { recorded = record(cmd, s, 0); });
  if (!recorded) return recorded.error();
  auto out = collect(0);
  if (!out || !s.readImage) return out;
  std::vector<uint8_t> raw = readbackImage(d.ctx, d.color, VK_IMAGE_LAYOUT_GENERAL, 8);
  convertHalfImage(raw, d.width, d.height, s.readLinear, *out);
  return out;
}

} // namespace mirage::render
