// SurfelRenderer's frames (docs/surfels.md, "Rendering"): settings -> plan and SurfelRenderFrame,
// the per-frame command sequence, render / record / collect, and the mixed-scene stage the
// cluster renderer runs inside its own frames.
#include <algorithm>
#include <cstring>

#include <fmt/format.h>

#include "render_util.h"
#include "surfel_impl.h"
#include "mirage/gpu/commands.h"
#include "mirage/render/camera.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

namespace {

// SurfelRenderFrame::flags of the settings both paths share (the caller adds the source).
uint32_t frameFlags(const SurfelRenderSettings& ss) {
  uint32_t merge = ss.merge == SurfelMerge::On     ? MIRAGE_SURFEL_MERGE_ALL
                   : ss.merge == SurfelMerge::Auto ? MIRAGE_SURFEL_MERGE_AUTO
                                                   : 0u;
  return (ss.frustumCulling ? MIRAGE_SURFEL_FRUSTUM_CULL : 0u) | (ss.allSurfels ? MIRAGE_SURFEL_ALL : 0u) |
         (ss.meshFade ? MIRAGE_SURFEL_MESH_FADE : 0u) | (ss.backfaceCulling ? MIRAGE_SURFEL_BACKFACE_CULL : 0u) |
         merge | (ss.orientedDiscs ? MIRAGE_SURFEL_ORIENTED : 0u);
}

Status checkSurfelSize(float size) {
  if (!(size >= 0.5f && size <= 16.0f)) return Error{fmt::format("--surfel-size {} must be in 0.5..16 pixels", size)};
  return Ok{};
}

Status checkSlot(uint32_t slot) {
  if (slot >= kMaxFramesInFlight)
    return Error{fmt::format("frame slot {} is outside 0..{}", slot, kMaxFramesInFlight - 1)};
  return Ok{};
}

} // namespace

Result<SurfelFramePlan> SurfelRenderer::Impl::plan(const SurfelRenderSettings& ss) const {
  const RenderSettings& s = ss.base;
  if (s.width == 0 || s.height == 0 || s.width > kMaxRenderDimension || s.height > kMaxRenderDimension)
    return Error{fmt::format("render size {}x{} is outside 1..{}", s.width, s.height, kMaxRenderDimension)};
  if (Status st = checkSurfelSize(ss.surfelSize); !st) return st.error();
  SurfelFramePlan p;
  bool atomics = ctx.caps().int64BufferAtomics;
  p.raster = ss.raster == SurfelRaster::Auto ? (atomics ? SurfelRaster::Compute : SurfelRaster::Raster) : ss.raster;
  if (p.raster == SurfelRaster::Compute && !atomics)
    return Error{"--surfel-raster compute: the device has no 64-bit buffer atomics"};
  p.cullBackFaces = ss.backfaceCulling;
  p.subgroupMerge = ss.merge != SurfelMerge::Off;
  if (ss.stereoIpd) {
    if (Status st = validateIpd(*ss.stereoIpd); !st) return st.error();
    if (uint64_t(s.width) * 2 > kMaxRenderDimension)
      return Error{fmt::format("--stereo: the side-by-side target {}x{} exceeds {} pixels across", s.width * 2,
                               s.height, kMaxRenderDimension)};
    if (p.raster != SurfelRaster::Compute)
      return Error{"--stereo splats surfels with the compute splat only (64-bit buffer atomics), not --surfel-raster "
                   "raster"};
    p.eyes = 2;
  }
  return p;
}

Status SurfelRenderer::Impl::prepareFrame(const SurfelRenderSettings& ss, uint32_t slot) {
  auto planned = plan(ss);
  if (!planned) return planned.error();
  const RenderSettings& s = ss.base;
  sio::SurfelRenderFrame f{};
  f.eyes = planned->eyes;
  if (planned->eyes == 2) { // the left eye's camera; the right eye is its offset and clip x shift
    std::array<Camera, 2> eyes = stereoEyesSharedClip(s.camera, *ss.stereoIpd, worldBounds);
    f.camera = viewFrame(eyes[0], s.width, s.height);
    auto dx = stereoClipDx(f.camera, *ss.stereoIpd);
    if (!dx) return dx.error();
    f.stereoEye = glm::vec4(eyes[1].eye - eyes[0].eye, *dx);
  } else {
    f.camera = viewFrame(withClipPlanes(s.camera, worldBounds), s.width, s.height);
  }
  f.lightDir = glm::vec4(glm::normalize(s.lightDirection), s.lightIntensity);
  f.skyAmbient = glm::vec4(s.skyAmbient, 0.0f);
  f.groundAmbient = glm::vec4(s.groundAmbient, 0.0f);
  f.background = s.background;
  f.lightAddress = lights.address();
  f.lightCount = lightCount;
  f.surfelSize = ss.surfelSize;
  f.fadeBand = std::max(ss.fadeBand, 0.0f);
  f.flags = frameFlags(ss) | (planned->raster == SurfelRaster::Compute ? MIRAGE_SURFEL_SOURCE_BUFFER : 0u);
  f.instanceCount = instanceCount;

  currentSlot = slot;
  retired.completed(slot); // a slot is recorded again only after its previous frame completed
  recorded[slot] = false;
  plans[slot] = *planned;
  ensureTargets(s.width, s.height, s.width * planned->eyes);
  writeDescriptors(slot);
  std::memcpy(frames[slot].mapped(), &f, sizeof(f));
  return Ok{};
}

// barriers: on entry the counters were zeroed by a transfer and made visible to compute. On exit
// the instance states, draws and dispatch arguments are written and visible to the indirect,
// vertex, fragment and compute stages and to copies.
void SurfelRenderer::Impl::cmdPrefix(VkCommandBuffer cmd, const sio::SurfelRenderPush& p, GpuTimer& t) {
  uint32_t slot = t.cmdBegin(cmd, "prefix", kCS);
  vkCmdPushConstants(cmd, layout, kSurfelPushStages, 0, sizeof(p), &p);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, prefixPipeline);
  vkCmdDispatch(cmd, (instanceCount + MIRAGE_SURFEL_INSTANCE_WORKGROUP - 1) / MIRAGE_SURFEL_INSTANCE_WORKGROUP, 1, 1);
  cmdMemoryBarrier(cmd, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCS, kStorageRW);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, scanPipeline);
  vkCmdDispatch(cmd, 1, 1, 1);
  cmdMemoryBarrier(cmd, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT |
                       VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | kCS | VK_PIPELINE_STAGE_2_COPY_BIT,
                   VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT |
                       VK_ACCESS_2_TRANSFER_READ_BIT);
  t.cmdEnd(cmd, slot, kCS);
}

// barriers: cmdPrefix's outputs visible; for compute, the 64-bit visibility buffer zeroed and
// visible to compute. On exit the visibility image is in SHADER_READ_ONLY_OPTIMAL and whatever the
// splat wrote is visible to the resolve (compute) and to copies (tests read the ids back).
void SurfelRenderer::Impl::cmdSplat(VkCommandBuffer cmd, const SurfelFramePlan& plan, GpuTimer& t) {
  uint32_t slot = t.cmdBegin(cmd, "splat");
  ImageBarrier toRead{vis.handle(),
                      VK_PIPELINE_STAGE_2_NONE,
                      0,
                      kCS | VK_PIPELINE_STAGE_2_COPY_BIT,
                      VK_ACCESS_2_SHADER_SAMPLED_READ_BIT | VK_ACCESS_2_TRANSFER_READ_BIT,
                      VK_IMAGE_LAYOUT_UNDEFINED,
                      VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  if (plan.raster == SurfelRaster::Compute) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, splatPipeline(plan));
    vkCmdDispatchIndirect(cmd, counters.handle(), offsetof(sio::SurfelRenderCounters, splatArgs));
    cmdMemoryBarrier(cmd, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCS | VK_PIPELINE_STAGE_2_COPY_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_TRANSFER_READ_BIT);
    if (vis) cmdImageBarrier(cmd, toRead); // unused by the resolve here, but the descriptor must be valid
    t.cmdEnd(cmd, slot);
    return;
  }
  ImageBarrier toAttachment[] = {
      {vis.handle(), kCS | VK_PIPELINE_STAGE_2_COPY_BIT, 0, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
       VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL},
      {depth.handle(), VK_PIPELINE_STAGE_2_NONE, 0,
       VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
       VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
       VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_ASPECT_DEPTH_BIT}};
  cmdImageBarriers(cmd, toAttachment);
  VkRenderingAttachmentInfo visAtt{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  visAtt.imageView = vis.view();
  visAtt.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  visAtt.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR; // id 0 = background
  visAtt.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  VkRenderingAttachmentInfo depthAtt{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  depthAtt.imageView = depth.view();
  depthAtt.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  depthAtt.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR;
  depthAtt.storeOp = VK_ATTACHMENT_STORE_OP_DONT_CARE;
  depthAtt.clearValue.depthStencil = {0.0f, 0}; // reverse-Z: far is 0
  VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
  ri.renderArea = {{0, 0}, {width, height}};
  ri.layerCount = 1;
  ri.colorAttachmentCount = 1;
  ri.pColorAttachments = &visAtt;
  ri.pDepthAttachment = &depthAtt;
  vkCmdBeginRendering(cmd, &ri);
  cmdSetFullViewport(cmd, width, height);
  vkCmdSetCullMode(cmd, VK_CULL_MODE_NONE);
  vkCmdSetFrontFace(cmd, VK_FRONT_FACE_COUNTER_CLOCKWISE);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, rasterPipeline);
  // One draw per instance (culled ones draw 0 vertices); firstInstance carries the instance index.
  vkCmdDrawIndirect(cmd, draws.handle(), 0, instanceCount, sizeof(VkDrawIndirectCommand));
  vkCmdEndRendering(cmd);
  toRead.srcStage = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
  toRead.srcAccess = VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT;
  toRead.oldLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  cmdImageBarrier(cmd, toRead);
  t.cmdEnd(cmd, slot);
}

// barriers: cmdSplat's output visible to compute. The colour target ends in GENERAL with the
// resolve's writes available, which the readback and the callers of record() expect.
void SurfelRenderer::Impl::cmdResolve(VkCommandBuffer cmd, const sio::SurfelRenderPush& p) {
  uint32_t slot = timer().cmdBegin(cmd, "resolve");
  cmdImageBarrier(cmd, {color.handle(), VK_PIPELINE_STAGE_2_NONE, 0, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                        VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL});
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, resolvePipeline);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &descriptors[currentSlot].set, 0, nullptr);
  vkCmdPushConstants(cmd, layout, kSurfelPushStages, 0, sizeof(p), &p);
  vkCmdDispatch(cmd, (colorWidth + 7) / 8, (height + 7) / 8, 1); // both eyes in stereo
  timer().cmdEnd(cmd, slot);
}

// barriers: the counters' writes (prefix, scan) visible to transfers on entry; the copy is made
// visible to the host by the caller (cmdFrame, or the cluster frame's end for the stage).
void SurfelRenderer::Impl::cmdCountersToReadback(VkCommandBuffer cmd) {
  VkBufferCopy region{0, 0, sizeof(sio::SurfelRenderCounters)};
  vkCmdCopyBuffer(cmd, counters.handle(), readbacks[currentSlot].handle(), 1, &region);
}

// One frame's commands; prepareFrame ran for `currentSlot`.
// barriers: the first one orders this frame after all work submitted before it on the queue, so
// the GPU-only scratch every slot shares (counters, states, draws, batches, visibility, targets) is
// never written while an earlier frame still reads it. Per slot are only what the CPU touches
// while other frames run: the frame upload, the counter readback, the timestamps and the
// descriptor set. On exit the counters are in readbacks[currentSlot] (visible to the host) and the
// colour target is in GENERAL, written by the resolve.
void SurfelRenderer::Impl::cmdFrame(VkCommandBuffer cmd) {
  const SurfelFramePlan& plan = plans[currentSlot];
  sio::SurfelRenderPush p = push();
  GpuTimer& t = timer();
  t.cmdReset(cmd);
  uint32_t frameTime = t.cmdBegin(cmd, "frame");
  cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                   VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                   VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
  uint32_t clearTime = t.cmdBegin(cmd, "clear", VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT);
  vkCmdFillBuffer(cmd, counters.handle(), 0, VK_WHOLE_SIZE, 0);
  if (plan.raster == SurfelRaster::Compute) vkCmdFillBuffer(cmd, visBuffer.handle(), 0, VK_WHOLE_SIZE, 0);
  t.cmdEnd(cmd, clearTime, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT);
  // Shaders reach these buffers through addresses, which synchronization validation does not
  // track: make the clears visible to every later reader directly.
  cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                   kCS | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT, kStorageRW | VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT);
  cmdPrefix(cmd, p, t);   // cull, k per instance (stereo: once, from the nearer eye), ids, batches, dispatch
  cmdSplat(cmd, plan, t); // visibility: (depth, surfel id) per pixel (stereo: both eyes, each surfel loaded once)
  cmdResolve(cmd, p);     // fetch and shade (stereo: both halves)
  t.cmdEnd(cmd, frameTime);
  cmdCountersToReadback(cmd);
  cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
  recorded[currentSlot] = true;
}

// The slot's counters as its frame copied them.
SurfelRenderOutput SurfelRenderer::Impl::readCounters(uint32_t slot) const {
  const SurfelFramePlan& plan = plans[slot];
  sio::SurfelRenderCounters c{};
  std::memcpy(&c, readbacks[slot].mapped(), sizeof(c));
  SurfelRenderOutput out;
  out.raster = plan.raster;
  out.visibleInstances = c.visibleInstances;
  out.fadingInstances = c.fadingInstances;
  out.mergedInstances = plan.raster == SurfelRaster::Compute && plan.subgroupMerge ? c.mergedInstances : 0;
  out.surfelsSplatted = c.totalSurfels;
  out.image.stats.drawCalls = plan.raster == SurfelRaster::Raster ? 1 : 0;
  return out;
}

Status SurfelRenderer::record(VkCommandBuffer cmd, const SurfelRenderSettings& settings, uint32_t slot) {
  if (Status st = checkSlot(slot); !st) return st;
  if (settings.readInstanceStates) return Error{"reading the surfel instance states needs render(), not record()"};
  Impl& d = *impl_;
  if (Status st = d.prepareFrame(settings, slot); !st) return st;
  d.cmdFrame(cmd);
  return Ok{};
}

Result<SurfelRenderOutput> SurfelRenderer::collect(uint32_t slot) {
  Impl& d = *impl_;
  if (slot >= kMaxFramesInFlight || !d.recorded[slot])
    return Error{fmt::format("frame slot {} holds no recorded frame", slot)};
  SurfelRenderOutput out = d.readCounters(slot);
  out.image.stats.passTimes = d.timers[slot].read();
  d.recorded[slot] = false;
  d.retired.completed(slot);
  return out;
}

const gpu::Image& SurfelRenderer::colorTarget() const { return impl_->color; }

Result<SurfelRenderOutput> SurfelRenderer::render(const SurfelRenderSettings& ss) {
  const RenderSettings& s = ss.base;
  Impl& d = *impl_;
  if (Status st = d.prepareFrame(ss, 0); !st) return st.error();
  d.ctx.submitAndWait([&](VkCommandBuffer cmd) { d.cmdFrame(cmd); });
  auto collected = collect(0);
  if (!collected) return collected.error();
  SurfelRenderOutput out = std::move(*collected);
  const SurfelFramePlan& plan = d.plans[0];
  bool compute = plan.raster == SurfelRaster::Compute;
  if (ss.readInstanceStates) {
    std::vector<sio::SurfelInstanceState> st(d.instanceCount);
    std::vector<uint8_t> raw = readbackBuffer(d.ctx, d.states, st.size() * sizeof(st[0]));
    std::memcpy(st.data(), raw.data(), raw.size());
    for (const auto& e : st) {
      out.prefix.push_back(e.count);
      out.fade.push_back(e.fade);
      out.distance.push_back(e.distance);
      out.merged.push_back(e.quantStep.w != 0.0f && plan.subgroupMerge && compute ? 1 : 0);
    }
    out.idBuffer.resize(size_t(d.colorWidth) * s.height);
    if (compute) {
      raw = readbackBuffer(d.ctx, d.visBuffer, out.idBuffer.size() * 8);
      out.depthBits.resize(out.idBuffer.size());
      for (size_t i = 0; i < out.idBuffer.size(); ++i) {
        std::memcpy(&out.idBuffer[i], raw.data() + i * 8, 4);
        std::memcpy(&out.depthBits[i], raw.data() + i * 8 + 4, 4);
      }
    } else {
      raw = readbackImage(d.ctx, d.vis, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, 8);
      for (size_t i = 0; i < out.idBuffer.size(); ++i) std::memcpy(&out.idBuffer[i], raw.data() + i * 8, 4);
    }
  }
  if (!s.readImage) return out;
  std::vector<uint8_t> img = readbackImage(d.ctx, d.color, VK_IMAGE_LAYOUT_GENERAL, 8);
  convertHalfImage(img, d.colorWidth, s.height, s.readLinear, out.image);
  return out;
}

Status SurfelRenderer::stagePrepare(const SurfelRenderSettings& ss, const SurfelStageFrame& sf) {
  Impl& d = *impl_;
  if (!d.ctx.caps().int64BufferAtomics) return Error{"mixed mesh/surfel rendering needs 64-bit buffer atomics"};
  if (Status st = checkSlot(sf.slot); !st) return st;
  if (Status st = checkSurfelSize(ss.surfelSize); !st) return st;
  // Surfel ids carry MIRAGE_SURFEL_ID_TAG, so the id space halves.
  if (d.instancedCount >= MIRAGE_SURFEL_ID_TAG) return Error{"mixed scene: more than 2^31 - 1 instanced surfels"};
  sio::SurfelRenderFrame f{};
  f.camera = sf.camera;
  f.surfelSize = ss.surfelSize;
  f.fadeBand = std::max(ss.fadeBand, 0.0f);
  f.flags = frameFlags(ss) | MIRAGE_SURFEL_SOURCE_BUFFER;
  f.instanceCount = d.instanceCount;
  f.idTag = MIRAGE_SURFEL_ID_TAG;
  f.eyes = sf.eyes == 2 ? 2u : 1u;
  f.stereoEye = sf.stereoEye;
  d.currentSlot = sf.slot;
  SurfelFramePlan& plan = d.plans[sf.slot];
  plan = {};
  plan.raster = SurfelRaster::Compute;
  plan.cullBackFaces = ss.backfaceCulling;
  plan.subgroupMerge = ss.merge != SurfelMerge::Off;
  plan.eyes = f.eyes;
  std::memcpy(d.frames[sf.slot].mapped(), &f, sizeof(f));
  sio::SurfelRenderPush& p = d.stagePush[sf.slot];
  p = d.push();
  p.visBufferAddress = sf.visBufferAddress;
  p.meshFadeAddress = sf.meshFadeAddress;
  return Ok{};
}

void SurfelRenderer::stageCmdClear(VkCommandBuffer cmd) {
  vkCmdFillBuffer(cmd, impl_->counters.handle(), 0, VK_WHOLE_SIZE, 0);
}
void SurfelRenderer::stageCmdPrefix(VkCommandBuffer cmd, GpuTimer& timer) {
  impl_->cmdPrefix(cmd, impl_->stagePush[impl_->currentSlot], timer);
}
void SurfelRenderer::stageCmdSplat(VkCommandBuffer cmd, GpuTimer& timer) {
  // The cluster passes between the prefix and here pushed their own constants (another layout):
  // push ours again, else the splat reads the cluster push's addresses as its own.
  Impl& d = *impl_;
  const sio::SurfelRenderPush& p = d.stagePush[d.currentSlot];
  vkCmdPushConstants(cmd, d.layout, kSurfelPushStages, 0, sizeof(p), &p);
  d.cmdSplat(cmd, d.plans[d.currentSlot], timer);
}
void SurfelRenderer::stageCmdFinish(VkCommandBuffer cmd) { impl_->cmdCountersToReadback(cmd); }

sio::ClusterSurfelLink SurfelRenderer::stageLink() const {
  const Impl& d = *impl_;
  sio::ClusterSurfelLink l{};
  l.stateAddress = d.states.address();
  l.instanceAddress = d.instances.address();
  l.cloudAddress = d.clouds.address();
  l.positionAddress = d.positions.address();
  l.attributeAddress = d.attributes.address();
  l.materialAddress = d.materials.address();
  l.instanceCount = d.instanceCount;
  return l;
}

SurfelStageStats SurfelRenderer::stageStats(uint32_t slot) const {
  if (slot >= kMaxFramesInFlight) return {};
  SurfelRenderOutput c = impl_->readCounters(slot);
  return {c.visibleInstances, c.fadingInstances, c.surfelsSplatted};
}

} // namespace mirage::render
