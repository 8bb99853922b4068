// Alpha BLEND in the forward renderer (docs/render.md, "Transparency"), after the opaque pass:
// linked lists (build: every blended fragment appended, forward_oit.frag; resolve: sorted per
// pixel, forward_oit_resolve.comp; the code shared with the cluster composite, oit_list.glsl),
// weighted blended OIT (accumulate + revealage, forward_weighted_resolve.comp), or the sorted
// reference (every blended triangle back to front by its centroid's view depth, hardware "over",
// with the particles sorted by the same depth drawn between them).
#include <algorithm>
#include <cstring>

#include "forward_impl.h"
#include "mirage/gpu/commands.h"
#include "mirage/render/particle_draw.h"
#include "render_util.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

namespace {

constexpr VkPipelineStageFlags2 kFS = VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
constexpr VkPipelineStageFlags2 kTests =
    VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
} // namespace

VkPipelineColorBlendAttachmentState forwardWeightedBlend() {
  VkPipelineColorBlendAttachmentState b{};
  b.blendEnable = VK_TRUE;
  b.srcColorBlendFactor = VK_BLEND_FACTOR_ONE;
  b.dstColorBlendFactor = VK_BLEND_FACTOR_ONE;
  b.srcAlphaBlendFactor = VK_BLEND_FACTOR_ZERO;
  b.dstAlphaBlendFactor = VK_BLEND_FACTOR_ONE_MINUS_SRC_ALPHA;
  b.colorBlendOp = b.alphaBlendOp = VK_BLEND_OP_ADD;
  b.colorWriteMask =
      VK_COLOR_COMPONENT_R_BIT | VK_COLOR_COMPONENT_G_BIT | VK_COLOR_COMPONENT_B_BIT | VK_COLOR_COMPONENT_A_BIT;
  return b;
}

void ForwardRenderer::Impl::uploadTransparency(const Scene& scene) {
  // The lists and resolve state exist without blended geometry too: particles (particle_draw.cpp)
  // may be drawn through them.
  std::vector<sio::GpuInstance> data;
  blendPositions.resize(scene.meshes.size());
  blendIndices.resize(scene.meshes.size());
  for (const Instance& inst : blendInstances) {
    data.push_back(makeGpuInstance(inst.transform));
    const Mesh& m = scene.meshes[inst.mesh];
    if (blendIndices[inst.mesh].empty()) blendPositions[inst.mesh] = m.positions, blendIndices[inst.mesh] = m.indices;
    blendTriangles += m.indices.size() / 3;
  }
  if (!data.empty())
    blendInstanceBuffer =
        createBufferWithData<sio::GpuInstance>(ctx, data, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "blend instances");
  oitCounters = createBuffer(ctx, sizeof(sio::OitCounters),
                             VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                 VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                             MemoryUsage::GpuOnly, "oit counters");
  VkDescriptorSetLayoutBinding bindings[3];
  for (uint32_t b = 0; b < 3; ++b)
    bindings[b] = {b, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  for (uint32_t i = 0; i < kMaxFramesInFlight; ++i) {
    oitLists[i] =
        createBuffer(ctx, sizeof(sio::OitLists), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::Upload, "oit lists");
    oitReadback[i] = createBuffer(ctx, sizeof(sio::OitCounters), VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                  MemoryUsage::Readback, "oit counters readback");
    sortedIndices[i] = createBuffer(ctx, std::max<uint64_t>(blendTriangles, 1) * 3 * sizeof(uint32_t),
                                    VK_BUFFER_USAGE_INDEX_BUFFER_BIT, MemoryUsage::Upload, "sorted blend indices");
    sortedDepths[i] = createBuffer(ctx, std::max<uint64_t>(blendTriangles, 1) * sizeof(float),
                                   VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::Upload, "sorted blend depths");
    sortedGaps[i] = createBuffer(ctx, (blendTriangles + 1) * sizeof(VkDrawIndirectCommand),
                                 VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT |
                                     VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                 MemoryUsage::GpuOnly, "sorted particle gaps");
    resolveDescriptors[i] = createDescriptorSet(ctx, bindings);
  }
}

// The pipelines of a mode, made on its first frame (most scenes use one mode).
static void ensurePipelines(ForwardRenderer::Impl& d, OitMode mode) {
  GraphicsPipelineDesc g;
  g.vertexShader = "forward.vert";
  g.layout = d.layout;
  g.bindings = {{0, sizeof(sio::GpuVertex), VK_VERTEX_INPUT_RATE_VERTEX}};
  g.attributes = {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(sio::GpuVertex, position)},
                  {1, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(sio::GpuVertex, normal)},
                  {2, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(sio::GpuVertex, uv)},
                  {3, 0, VK_FORMAT_R32G32B32A32_SFLOAT, offsetof(sio::GpuVertex, tangent)},
                  {4, 0, VK_FORMAT_R8G8B8A8_UNORM, offsetof(sio::GpuVertex, color)}};
  g.depthFormat = kForwardDepthFormat;
  g.depthWrite = false; // blended surfaces test against the opaque depth but do not occlude each other
  if (!d.resolveLayout)
    d.resolveLayout = createPipelineLayout(d.ctx, {d.resolveDescriptors[0].layout.get()},
                                           sizeof(sio::ForwardResolvePush), VK_SHADER_STAGE_COMPUTE_BIT);
  if (mode == OitMode::Sorted && !d.sortedPipeline) {
    g.fragmentShader = "forward.frag";
    g.colorFormats = {kForwardColorFormat};
    g.alphaBlend = true;
    d.sortedPipeline = createGraphicsPipeline(d.ctx, g);
  } else if (mode == OitMode::LinkedList && !d.appendPipeline) {
    g.fragmentShader = "forward_oit.frag"; // no colour output: the lists are the result
    d.appendPipeline = createGraphicsPipeline(d.ctx, g);
    d.resolvePipeline = createComputePipeline(d.ctx, "forward_oit_resolve.comp", d.resolveLayout);
  } else if (mode == OitMode::Weighted && !d.weightedPipeline) {
    g.fragmentShader = "forward_weighted.frag";
    g.colorFormats = {kForwardAccumFormat, kForwardAccumFormat};
    g.colorBlends = {forwardWeightedBlend(), forwardWeightedBlend()};
    d.weightedPipeline = createGraphicsPipeline(d.ctx, g);
    d.weightedResolvePipeline = createComputePipeline(d.ctx, "forward_weighted_resolve.comp", d.resolveLayout);
  }
}

// The lists' pool for the current target size: nodesPerPixel per pixel, capped by what one storage
// buffer may address. Replaced ones wait for the frames in flight that use them.
void ForwardRenderer::Impl::ensureOitTargets(uint32_t nodesPerPixel) {
  if (oitHeads && oitNodesPerPixel == nodesPerPixel) return;
  retired.retire(std::move(oitHeads), inFlight());
  retired.retire(std::move(oitNodes), inFlight());
  retired.retire(std::move(oitColors), inFlight());
  uint64_t pixels = uint64_t(colorWidth) * height;
  oitHeads = createBuffer(ctx, pixels * sizeof(sio::OitPixelHead),
                          VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::GpuOnly,
                          "oit heads");
  oitNodeCapacity = uint32_t(
      std::min<uint64_t>({pixels * nodesPerPixel, ctx.caps().maxStorageBufferRange / 12, uint64_t(UINT32_MAX) - 1}));
  oitNodes = createBuffer(ctx, uint64_t(oitNodeCapacity) * sizeof(sio::OitNode),
                          VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::GpuOnly,
                          "oit nodes");
  oitNodesUnzeroed = true;
  oitColors = createBuffer(ctx, uint64_t(oitNodeCapacity) * 8, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::GpuOnly,
                           "oit colours");
  oitNodesPerPixel = nodesPerPixel;
}

bool ForwardRenderer::Impl::splatsParticles(const ForwardRenderSettings& fs) const {
  return fs.particles && fs.particles->batchCount() != 0 && fs.particles->splats(fs.oit);
}

ParticleSplatTarget ForwardRenderer::Impl::splatTarget(uint32_t slot, uint32_t eyeCount) {
  ParticleSplatTarget t;
  t.slot = slot;
  t.eyes = eyeCount;
  for (uint32_t e = 0; e < eyeCount; ++e) t.frames[e] = frames[slot].address() + e * sizeof(sio::FrameData);
  t.eyeWidth = eyeWidth;
  t.height = height;
  t.depth = depth.view();
  t.color = color.view();
  t.accumulators = &splatAccum;
  t.timer = &timers[slot];
  return t;
}

void ForwardRenderer::Impl::prepareTransparency(VkCommandBuffer cmd, const ForwardRenderSettings& fs, uint32_t slot,
                                                const glm::mat4& view) {
  slotOit[slot] = false;
  slotSortsParticles[slot] = false;
  bool particles = fs.particles && fs.particles->batchCount() != 0;
  if (blendInstances.empty() && !particles) return;
  if (particles) fs.particles->cmdPrepare(cmd);
  if (particles && fs.particles->splats(fs.oit)) { // the splat's sums, zeroed (cmdSplat waits for it)
    uint64_t bytes = fs.particles->splatBytes(uint64_t(colorWidth) * height);
    if (!splatAccum || splatAccum.size() != bytes) {
      retired.retire(std::move(splatAccum), inFlight());
      splatAccum = createBuffer(ctx, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                MemoryUsage::GpuOnly, "particle splat sums");
    }
    vkCmdFillBuffer(cmd, splatAccum.handle(), 0, VK_WHOLE_SIZE, 0);
  }
  ensurePipelines(*this, fs.oit);
  if (fs.oit == OitMode::LinkedList) {
    ensureOitTargets(fs.oitNodesPerPixel);
    sio::OitLists l{oitHeads.address(),  oitNodes.address(),
                    oitColors.address(), oitCounters.address(),
                    colorWidth,          height,
                    oitNodeCapacity,     0};
    std::memcpy(oitLists[slot].mapped(), &l, sizeof(l));
    vkCmdFillBuffer(cmd, oitHeads.handle(), 0, VK_WHOLE_SIZE, 0); // empty lists
    vkCmdFillBuffer(cmd, oitCounters.handle(), 0, VK_WHOLE_SIZE, 0);
    if (oitNodesUnzeroed) { // a new pool; afterwards the resolve leaves it zero (oit_list.glsl)
      vkCmdFillBuffer(cmd, oitNodes.handle(), 0, VK_WHOLE_SIZE, 0);
      oitNodesUnzeroed = false;
    }
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, kFS | kCS, kStorageRW);
    slotOit[slot] = true;
  } else if (fs.oit == OitMode::Weighted) {
    if (!accum || accum.extent().width != colorWidth || accum.extent().height != height) {
      retired.retire(std::move(accum), inFlight());
      retired.retire(std::move(reveal), inFlight());
      VkImageUsageFlags usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_STORAGE_BIT;
      accum = createImage2D(ctx, colorWidth, height, kForwardAccumFormat, usage, "oit accumulation");
      reveal = createImage2D(ctx, colorWidth, height, kForwardAccumFormat, usage, "oit revealage");
    }
  } else {
    // Every blended triangle by its centroid's view depth (more negative = farther first), ties by
    // instance and triangle: exact where no two triangles overlap in depth across a pixel
    // (non-intersecting, or split along their intersections), the reference the tests compare with.
    // With a visible set only its listed triangles.
    struct Key {
      float z;
      uint32_t instance, triangle;
    };
    std::vector<Key> keys;
    keys.reserve(blendTriangles);
    auto addKeys = [&](uint32_t i, const std::vector<uint32_t>* listed) {
      const Instance& inst = blendInstances[i];
      glm::mat4 mv = view * inst.transform;
      const std::vector<glm::vec3>& p = blendPositions[inst.mesh];
      const std::vector<uint32_t>& idx = blendIndices[inst.mesh];
      size_t count = listed ? listed->size() : idx.size() / 3;
      for (size_t k = 0; k < count; ++k) {
        uint32_t t = listed ? (*listed)[k] : uint32_t(k);
        glm::vec3 c = (p[idx[t * 3]] + p[idx[t * 3 + 1]] + p[idx[t * 3 + 2]]) / 3.0f;
        keys.push_back({(mv * glm::vec4(c, 1.0f)).z, i, t});
      }
    };
    if (visible.active)
      for (const ForwardBlendRange& b : visible.blend) addKeys(b.blendInstance, &b.triangles);
    else
      for (uint32_t i = 0; i < blendInstances.size(); ++i) addKeys(i, nullptr);
    std::stable_sort(keys.begin(), keys.end(), [](const Key& a, const Key& b) { return a.z < b.z; });
    auto* out = reinterpret_cast<uint32_t*>(sortedIndices[slot].mapped());
    auto* depths = reinterpret_cast<float*>(sortedDepths[slot].mapped());
    std::vector<SortedRun>& runs = sortedRuns[slot];
    runs.clear();
    for (size_t k = 0; k < keys.size(); ++k) {
      const std::vector<uint32_t>& idx = blendIndices[blendInstances[keys[k].instance].mesh];
      std::memcpy(out + k * 3, &idx[keys[k].triangle * 3], 3 * sizeof(uint32_t));
      depths[k] = keys[k].z;
      if (runs.empty() || runs.back().blendInstance != keys[k].instance)
        runs.push_back({keys[k].instance, uint32_t(k * 3), 0});
      runs.back().indexCount += 3;
    }
    // The particles sorted by the same view depth on the GPU, each run of them drawn between the
    // two triangles it falls between (cmdTransparency).
    if (particles) {
      fs.particles->cmdSort(cmd, view, sortedDepths[slot].address(), uint32_t(keys.size()), sortedGaps[slot]);
      slotSortsParticles[slot] = true;
    }
  }
}

void ForwardRenderer::Impl::cmdTransparency(VkCommandBuffer cmd, const ForwardRenderSettings& fs, uint32_t slot,
                                            uint32_t eyeCount, FrameStats& frameStats) {
  const VkImageLayout kAttachment = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  const VkPipelineStageFlags2 kColorOut = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
  // The colour into GENERAL for the resolves (or the caller), its attachment writes visible.
  auto colorToGeneral = [&] {
    cmdImageBarrier(cmd, {color.handle(), kColorOut, VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                          kCS | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, kStorageRW | VK_ACCESS_2_TRANSFER_READ_BIT,
                          kAttachment, VK_IMAGE_LAYOUT_GENERAL});
  };
  GpuTimer& timer = timers[slot];
  bool particles = fs.particles && fs.particles->batchCount() != 0;
  if (blendInstances.empty() && !particles) { // the pass is still reported (0 ms), as every frame's report has it
    timer.cmdEnd(cmd, timer.cmdBegin(cmd, "blend"));
    return colorToGeneral();
  }
  // The opaque depth, stored by the opaque pass, tested (read-only) by the blended geometry and read
  // by the particle splat.
  cmdImageBarrier(cmd, {depth.handle(), kTests, VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, kTests | kCS,
                        VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
                        VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL,
                        VK_IMAGE_ASPECT_DEPTH_BIT});
  // Small particles splatted in compute before the pass (their sums resolved after the composite);
  // the billboards then draw the rest.
  const bool splat = splatsParticles(fs);
  ParticleSplatTarget splatAt;
  if (splat) {
    splatAt = splatTarget(slot, eyeCount);
    uint32_t splatTime = timer.cmdBegin(cmd, "splat", kCS);
    fs.particles->cmdSplat(cmd, splatAt);
    timer.cmdEnd(cmd, splatTime, kCS);
  }
  VkRenderingAttachmentInfo depthAtt{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  depthAtt.imageView = depth.view();
  depthAtt.imageLayout = VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL;
  depthAtt.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
  depthAtt.storeOp = VK_ATTACHMENT_STORE_OP_NONE; // nothing written
  VkRenderingAttachmentInfo colorAtts[2] = {{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO},
                                            {VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO}};
  VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
  ri.renderArea = {{0, 0}, {colorWidth, height}};
  ri.layerCount = 1;
  ri.pColorAttachments = colorAtts;
  ri.pDepthAttachment = &depthAtt;
  VkPipeline pipeline = appendPipeline;
  if (fs.oit == OitMode::Sorted) {
    colorAtts[0].imageView = color.view();
    colorAtts[0].imageLayout = kAttachment;
    colorAtts[0].loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
    colorAtts[0].storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    ri.colorAttachmentCount = 1;
    pipeline = sortedPipeline;
  } else if (fs.oit == OitMode::Weighted) {
    // Sums 0, revealage 1 (nothing covers): stored by compute (cmdClearTargets says why), loaded.
    ImageBarrier toClear[2], toAttachment[2];
    for (int i = 0; i < 2; ++i) {
      const Image& target = i == 0 ? accum : reveal;
      toClear[i] = {
          target.handle(),        kCS, 0, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
          VK_IMAGE_LAYOUT_GENERAL};
      toAttachment[i] = {target.handle(),
                         kCS,
                         VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                         kColorOut,
                         VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                         VK_IMAGE_LAYOUT_GENERAL,
                         kAttachment};
      colorAtts[i].imageView = target.view();
      colorAtts[i].imageLayout = kAttachment;
      colorAtts[i].loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
      colorAtts[i].storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    }
    cmdImageBarriers(cmd, toClear);
    if (!weightedClearPipeline)
      weightedClearPipeline = createComputePipeline(ctx, "forward_weighted_clear.comp", clearLayout);
    cmdClearDispatch(cmd, slot, weightedClearPipeline, glm::vec4(0.0f, 0.0f, 0.0f, 1.0f));
    cmdImageBarriers(cmd, toAttachment);
    ri.colorAttachmentCount = 2;
    pipeline = weightedPipeline;
  }

  uint32_t blendTime = timer.cmdBegin(cmd, "blend");
  vkCmdBeginRendering(cmd, &ri);
  VkDeviceSize zero = 0;
  VkBuffer vb = vertices.handle();
  vkCmdBindVertexBuffers(cmd, 0, 1, &vb, &zero);
  // Linked lists and weighted draw the visible set's blended ranges (or whole meshes) in any order
  // (the resolve sorts); the sorted mode its slot's triangle order.
  VkBuffer indexBuffer = fs.oit == OitMode::Sorted ? sortedIndices[slot].handle()
                         : visible.active          ? visible.indices.handle()
                                                   : indices.handle();
  vkCmdBindIndexBuffer(cmd, indexBuffer, 0, VK_INDEX_TYPE_UINT32);
  auto bindScene = [&] { // again after particle draws, which bind their own
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout, 0, 1, &descriptors.set, 0, nullptr);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
  };
  bindScene();
  VkDeviceAddress oit = fs.oit == OitMode::LinkedList ? oitLists[slot].address() : 0;
  const bool interleave = fs.oit == OitMode::Sorted && slotSortsParticles[slot];
  for (uint32_t e = 0; e < eyeCount; ++e) {
    VkDeviceAddress frame = cmdSetEye(cmd, slot, e);
    auto draw = [&](uint32_t i, const ForwardDrawRange& range) {
      cmdDraw(cmd, frame, blendInstanceBuffer.address(), range, isMirrored(blendInstances[i].transform), i, 1,
              frameStats, oit);
    };
    if (interleave) { // gap k's particles, then triangle k: one draw each (the reference, not speed)
      uint32_t k = 0;
      for (const SortedRun& run : sortedRuns[slot])
        for (uint32_t t = 0; t < run.indexCount / 3; ++t, ++k) {
          fs.particles->cmdDrawGap(cmd, frame, sortedGaps[slot], k);
          bindScene();
          draw(run.blendInstance, {blendInstances[run.blendInstance].mesh, run.firstIndex + 3 * t, 3});
        }
      fs.particles->cmdDrawGap(cmd, frame, sortedGaps[slot], k); // nearer than every triangle
      frameStats.drawCalls += k + 1;
      bindScene();
    } else if (fs.oit == OitMode::Sorted) {
      for (const SortedRun& run : sortedRuns[slot])
        draw(run.blendInstance, {blendInstances[run.blendInstance].mesh, run.firstIndex, run.indexCount});
    } else if (visible.active) {
      for (const ForwardBlendRange& b : visible.blend) draw(b.blendInstance, b.range);
    } else {
      for (uint32_t i = 0; i < blendInstances.size(); ++i) draw(i, wholeMesh(blendInstances[i].mesh));
    }
  }
  if (particles && !interleave) // after the scene's blended geometry: the lists and weights take any order
    for (uint32_t e = 0; e < eyeCount; ++e) {
      fs.particles->cmdDraw(cmd, fs.oit, cmdSetEye(cmd, slot, e), oit);
      frameStats.drawCalls += fs.particles->batchCount();
    }
  vkCmdEndRendering(cmd);
  timer.cmdEnd(cmd, blendTime);
  colorToGeneral();
  if (fs.oit == OitMode::Sorted) return;

  // The resolve: per pixel over the opaque colour, in place.
  if (fs.oit == OitMode::LinkedList) {
    cmdMemoryBarrier(cmd, kFS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCS, kStorageRW); // it zeroes the nodes it reads
  } else {
    ImageBarrier toRead[2];
    for (int i = 0; i < 2; ++i)
      toRead[i] = {(i == 0 ? accum : reveal).handle(),
                   kColorOut,
                   VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                   kCS,
                   VK_ACCESS_2_SHADER_STORAGE_READ_BIT,
                   kAttachment,
                   VK_IMAGE_LAYOUT_GENERAL};
    cmdImageBarriers(cmd, toRead);
  }
  // The slot's set: written at the start of the frame (writeResolveSet).
  uint32_t resolveTime = timer.cmdBegin(cmd, "composite", kCS);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE,
                    fs.oit == OitMode::LinkedList ? resolvePipeline : weightedResolvePipeline);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, resolveLayout, 0, 1, &resolveDescriptors[slot].set, 0,
                          nullptr);
  sio::ForwardResolvePush push{oit, colorWidth, height};
  vkCmdPushConstants(cmd, resolveLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
  vkCmdDispatch(cmd, (colorWidth + 7) / 8, (height + 7) / 8, 1);
  timer.cmdEnd(cmd, resolveTime, kCS);
  if (splat) { // the splatted particles over the composited colour
    uint32_t splatResolveTime = timer.cmdBegin(cmd, "splat-resolve", kCS);
    fs.particles->cmdSplatResolve(cmd, splatAt);
    timer.cmdEnd(cmd, splatResolveTime, kCS);
  }
  // The colour's writes visible to compute and transfers, as without transparency; the counters
  // to the slot's readback.
  cmdMemoryBarrier(cmd, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCS | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                   kStorageRW | VK_ACCESS_2_TRANSFER_READ_BIT);
  if (fs.oit != OitMode::LinkedList) return;
  VkBufferCopy copy{0, 0, sizeof(sio::OitCounters)};
  vkCmdCopyBuffer(cmd, oitCounters.handle(), oitReadback[slot].handle(), 1, &copy);
  cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
}

} // namespace mirage::render
