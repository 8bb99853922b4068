#include "mirage/render/forward_renderer.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <functional>

#include <fmt/format.h>

#include "forward_impl.h"
#include "mirage/gpu/commands.h"
#include "render_util.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

sio::GpuInstance makeGpuInstance(const glm::mat4& m) { return {m, glm::transpose(glm::inverse(m))}; }

bool isMirrored(const glm::mat4& m) { return glm::determinant(glm::mat3(m)) < 0.0f; }

void ForwardRenderer::Impl::upload(const Scene& scene) {
  // Geometry: all meshes in one vertex and one index buffer.
  MergedGeometry merged = mergeSceneGeometry(scene);
  for (size_t k = 0; k < scene.meshes.size(); ++k) {
    const Mesh& m = scene.meshes[k];
    meshes.push_back(
        {merged.firstIndex[k], uint32_t(m.indices.size()), int32_t(merged.firstVertex[k]), m.material, m.bounds});
  }
  vertices = createBufferWithData<sio::GpuVertex>(ctx, merged.vertices, VK_BUFFER_USAGE_VERTEX_BUFFER_BIT, "vertices");
  // TRANSFER_SRC: a visible set's indices are copied out of it.
  indices = createBufferWithData<uint32_t>(
      ctx, merged.indices, VK_BUFFER_USAGE_INDEX_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT, "indices");

  // Materials, with texture indices into the bindless array. A material referring to a missing
  // texture falls back to the factor alone.
  sceneMaterials = scene.materials;
  if (sceneMaterials.empty()) sceneMaterials.push_back(Material{});
  materials = uploadMaterials(ctx, sceneMaterials, scene.textures.size(), mapTransforms, "materials");

  std::vector<sio::GpuPointLight> gpuLights = toGpuLights(scene.lights);
  lightCount = uint32_t(gpuLights.size());
  if (gpuLights.empty()) gpuLights.resize(1); // a buffer cannot be empty
  lights = createBufferWithData<sio::GpuPointLight>(ctx, gpuLights, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "lights");

  textures = uploadTextures(ctx, scene);
  sampler = makeSampler(ctx, VK_FILTER_LINEAR);

  VkDescriptorSetLayoutBinding binding{0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, uint32_t(textures.size()),
                                       VK_SHADER_STAGE_FRAGMENT_BIT, nullptr};
  descriptors = createDescriptorSet(ctx, {&binding, 1});
  std::vector<VkDescriptorImageInfo> infos;
  for (const Image& img : textures) infos.push_back({sampler, img.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL});
  writeImageDescriptors(ctx, descriptors.set, 0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, infos);

  // Instances: opaque/mask ones grouped by mesh (one instanced draw each); blend ones to the
  // transparency passes (uploadTransparency).
  sceneInstances = scene.instances;
  std::vector<std::vector<const Instance*>> byMesh(scene.meshes.size() * 2); // [mesh * 2 + mirrored]
  for (const Instance& inst : sceneInstances) {
    if (inst.mesh >= scene.meshes.size()) continue;
    if (isBlend(inst.mesh))
      blendInstances.push_back(inst);
    else
      byMesh[inst.mesh * 2 + isMirrored(inst.transform)].push_back(&inst);
  }
  std::vector<sio::GpuInstance> instanceData;
  for (uint32_t k = 0; k < byMesh.size(); ++k) {
    if (byMesh[k].empty()) continue;
    batches.push_back({wholeMesh(k / 2), (k & 1) != 0, uint32_t(instanceData.size()), uint32_t(byMesh[k].size())});
    for (const Instance* inst : byMesh[k]) instanceData.push_back(makeGpuInstance(inst->transform));
  }
  instanceBuffer =
      createBufferWithData<sio::GpuInstance>(ctx, instanceData, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "instances");
  for (uint32_t i = 0; i < kMaxFramesInFlight; ++i)
    frames[i] =
        createBuffer(ctx, 2 * sizeof(sio::FrameData), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::Upload, "frame");
  uploadTransparency(scene);
}

void ForwardRenderer::Impl::createPipelines() {
  layout = createPipelineLayout(ctx, {descriptors.layout.get()}, sizeof(sio::ForwardPush),
                                VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT);
  GraphicsPipelineDesc d;
  d.vertexShader = "forward.vert";
  d.fragmentShader = "forward.frag";
  d.layout = layout;
  d.bindings = {{0, sizeof(sio::GpuVertex), VK_VERTEX_INPUT_RATE_VERTEX}};
  d.attributes = {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(sio::GpuVertex, position)},
                  {1, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(sio::GpuVertex, normal)},
                  {2, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(sio::GpuVertex, uv)},
                  {3, 0, VK_FORMAT_R32G32B32A32_SFLOAT, offsetof(sio::GpuVertex, tangent)},
                  {4, 0, VK_FORMAT_R8G8B8A8_UNORM, offsetof(sio::GpuVertex, color)}};
  d.colorFormats = {kForwardColorFormat};
  d.depthFormat = kForwardDepthFormat;
  opaquePipeline = createGraphicsPipeline(ctx, d);
}

// New targets when the size changes; frames in flight keep drawing into the old ones, which are
// freed once those frames completed.
void ForwardRenderer::Impl::ensureTargets(uint32_t colorW, uint32_t h) {
  if (colorW == colorWidth && h == height) return;
  retired.retire(std::move(color), inFlight());
  retired.retire(std::move(depth), inFlight());
  retired.retire(std::move(accum), inFlight());
  retired.retire(std::move(reveal), inFlight());
  retired.retire(std::move(oitHeads), inFlight());
  retired.retire(std::move(oitNodes), inFlight());
  retired.retire(std::move(oitColors), inFlight());
  retired.retire(std::move(splatAccum), inFlight());
  oitNodeCapacity = oitNodesPerPixel = 0; // the pool follows the size (ensureOitTargets)
  // Storage: the transparency resolves blend into it.
  color = createImage2D(
      ctx, colorW, h, kForwardColorFormat,
      VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_STORAGE_BIT, "color");
  // Sampled: the particle splat tests against it (particle_draw.h). Transfer destination: cleared
  // by a copy (cmdClearTargets).
  depth = createImage2D(ctx, colorW, h, kForwardDepthFormat,
                        VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT |
                            VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                        "depth");
  retired.retire(std::move(depthFar), inFlight());
  depthFar = createImage2D(ctx, colorW, h, kForwardDepthFormat,
                           VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, "depth far");
  depthFarUnset = true;
  colorWidth = colorW;
  height = h;
}

void ForwardRenderer::Impl::writeResolveSet(uint32_t slot, OitMode oit) {
  VkDescriptorImageInfo images[3] = {{VK_NULL_HANDLE, color.view(), VK_IMAGE_LAYOUT_GENERAL}, {}, {}};
  writeImageDescriptors(ctx, resolveDescriptors[slot].set, 0, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, {images, 1});
  if (oit != OitMode::Weighted || !accum) return; // (no blended geometry and no particles: no weighted targets)
  images[1] = {VK_NULL_HANDLE, accum.view(), VK_IMAGE_LAYOUT_GENERAL};
  images[2] = {VK_NULL_HANDLE, reveal.view(), VK_IMAGE_LAYOUT_GENERAL};
  writeImageDescriptors(ctx, resolveDescriptors[slot].set, 1, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, {images + 1, 1});
  writeImageDescriptors(ctx, resolveDescriptors[slot].set, 2, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, {images + 2, 1});
}

void ForwardRenderer::Impl::cmdClearDispatch(VkCommandBuffer cmd, uint32_t slot, VkPipeline pipeline,
                                             const glm::vec4& value) {
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, clearLayout, 0, 1, &resolveDescriptors[slot].set, 0,
                          nullptr);
  sio::ForwardClearPush push{value, colorWidth, height, 0, 0};
  vkCmdPushConstants(cmd, clearLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
  vkCmdDispatch(cmd, (colorWidth + 7) / 8, (height + 7) / 8, 1);
}

// Clears. The render pass's clear and vkCmdClear*Image run at the fixed-function rate, slow on
// GPUs built for compute: on an H100 a 1920x1080 RGBA16F clear took 0.30 ms and a D32 one 0.15 ms,
// where a compute store of the colour and a copy of an image of far depth take 0.04 ms together
// (a copy from a buffer of zeros: 0.13 ms).
void ForwardRenderer::Impl::cmdClearTargets(VkCommandBuffer cmd, uint32_t slot, const glm::vec4& background) {
  if (!clearPipeline) { // with its layout, which the weighted targets' clear shares
    clearLayout = createPipelineLayout(ctx, {resolveDescriptors[0].layout.get()}, sizeof(sio::ForwardClearPush),
                                       VK_SHADER_STAGE_COMPUTE_BIT);
    clearPipeline = createComputePipeline(ctx, "forward_clear.comp", clearLayout);
  }
  if (depthFarUnset) { // once per target size: a clear at the slow rate, copied every frame after
    ImageBarrier toDst[] = {{depthFar.handle(), VK_PIPELINE_STAGE_2_NONE, 0, VK_PIPELINE_STAGE_2_CLEAR_BIT,
                             VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                             VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_ASPECT_DEPTH_BIT}};
    cmdImageBarriers(cmd, toDst);
    VkClearDepthStencilValue far{0.0f, 0}; // reverse-Z
    VkImageSubresourceRange range{VK_IMAGE_ASPECT_DEPTH_BIT, 0, 1, 0, 1};
    vkCmdClearDepthStencilImage(cmd, depthFar.handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &far, 1, &range);
    ImageBarrier toSrc[] = {{depthFar.handle(), VK_PIPELINE_STAGE_2_CLEAR_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                             VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT,
                             VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                             VK_IMAGE_ASPECT_DEPTH_BIT}};
    cmdImageBarriers(cmd, toSrc);
    depthFarUnset = false;
  }
  ImageBarrier toClear[] = {{color.handle(), VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, 0, kCS,
                             VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL},
                            {depth.handle(), VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, 0, VK_PIPELINE_STAGE_2_COPY_BIT,
                             VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED,
                             VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_ASPECT_DEPTH_BIT}};
  cmdImageBarriers(cmd, toClear);
  cmdClearDispatch(cmd, slot, clearPipeline, background);
  VkImageCopy region{};
  region.srcSubresource = region.dstSubresource = {VK_IMAGE_ASPECT_DEPTH_BIT, 0, 0, 1};
  region.extent = {colorWidth, height, 1};
  vkCmdCopyImage(cmd, depthFar.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, depth.handle(),
                 VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
  const VkPipelineStageFlags2 kTests =
      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
  ImageBarrier toAttachment[] = {
      {color.handle(), kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
       VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_IMAGE_LAYOUT_GENERAL,
       VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL},
      {depth.handle(), VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, kTests,
       VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
       VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_ASPECT_DEPTH_BIT}};
  cmdImageBarriers(cmd, toAttachment);
}

VkDeviceAddress ForwardRenderer::Impl::cmdSetEye(VkCommandBuffer cmd, uint32_t slot, uint32_t e) const {
  VkViewport vp{float(e * eyeWidth), 0.0f, float(eyeWidth), float(height), 0.0f, 1.0f};
  VkRect2D scissor{{int32_t(e * eyeWidth), 0}, {eyeWidth, height}};
  vkCmdSetViewport(cmd, 0, 1, &vp);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
  return frames[slot].address() + e * sizeof(sio::FrameData);
}

// The push constants and facing state of a draw of mesh `mesh`'s material.
void ForwardRenderer::Impl::cmdBindMeshDraw(VkCommandBuffer cmd, VkDeviceAddress frame, VkDeviceAddress instances,
                                            uint32_t mesh, bool mirrored, VkDeviceAddress oit) {
  uint32_t materialIndex = std::min<uint32_t>(meshes[mesh].material, uint32_t(sceneMaterials.size() - 1));
  sio::ForwardPush push{};
  push.frameAddress = frame;
  push.instanceAddress = instances;
  push.materialAddress = materials.address();
  push.materialIndex = materialIndex;
  push.oitAddress = oit;
  vkCmdPushConstants(cmd, layout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(push), &push);
  vkCmdSetCullMode(cmd, sceneMaterials[materialIndex].doubleSided ? VK_CULL_MODE_NONE : VK_CULL_MODE_BACK_BIT);
  vkCmdSetFrontFace(cmd, mirrored ? VK_FRONT_FACE_CLOCKWISE : VK_FRONT_FACE_COUNTER_CLOCKWISE);
}

void ForwardRenderer::Impl::cmdDraw(VkCommandBuffer cmd, VkDeviceAddress frame, VkDeviceAddress instances,
                                    const ForwardDrawRange& range, bool mirrored, uint32_t firstInstance,
                                    uint32_t count, FrameStats& fs, VkDeviceAddress oit) {
  cmdBindMeshDraw(cmd, frame, instances, range.mesh, mirrored, oit);
  vkCmdDrawIndexed(cmd, range.indexCount, count, range.firstIndex, meshes[range.mesh].vertexOffset, firstInstance);
  fs.drawCalls++;
  fs.trianglesSubmitted += uint64_t(range.indexCount / 3) * count;
}

ForwardRenderer::ForwardRenderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ForwardRenderer::~ForwardRenderer() = default;

Result<std::unique_ptr<ForwardRenderer>> ForwardRenderer::create(Context& context, const Scene& scene) {
  for (const Mesh& m : scene.meshes)
    if (m.positions.size() > uint64_t(INT32_MAX) || m.indices.size() > uint64_t(UINT32_MAX))
      return Error{scene.source + ": mesh '" + m.name + "' is too large for 32-bit indices"};
  auto impl = std::make_unique<Impl>(context);
  impl->upload(scene);
  impl->createPipelines();
  std::unique_ptr<ForwardRenderer> r(new ForwardRenderer(std::move(impl)));
  r->worldBounds_ = scene.worldBounds();
  return r;
}

namespace {

Status checkSettings(const ForwardRenderSettings& fs) {
  const RenderSettings& s = fs.base;
  if (s.width == 0 || s.height == 0 || s.width > kMaxRenderDimension || s.height > kMaxRenderDimension)
    return Error{fmt::format("render size {}x{} is outside 1..{}", s.width, s.height, kMaxRenderDimension)};
  if (fs.oitNodesPerPixel < 1 || fs.oitNodesPerPixel > 64)
    return Error{fmt::format("OIT node pool of {} nodes per pixel is outside 1..64", fs.oitNodesPerPixel)};
  if (fs.oit == OitMode::Auto || fs.oit == OitMode::Packed)
    return Error{fmt::format("--oit {}: the forward renderer draws linked-list, weighted or sorted", toString(fs.oit))};
  if (!fs.stereoIpd) return Ok{};
  if (Status st = validateIpd(*fs.stereoIpd); !st) return st.error();
  if (uint64_t(s.width) * 2 > kMaxRenderDimension)
    return Error{fmt::format("--stereo: the side-by-side target {}x{} exceeds {} pixels across", s.width * 2, s.height,
                             kMaxRenderDimension)};
  return Ok{};
}

} // namespace

Status ForwardRenderer::record(VkCommandBuffer cmd, const ForwardRenderSettings& fs, uint32_t slot) {
  const RenderSettings& s = fs.base;
  if (slot >= kMaxFramesInFlight)
    return Error{fmt::format("frame slot {} is outside 0..{}", slot, kMaxFramesInFlight - 1)};
  if (Status st = checkSettings(fs); !st) return st.error();
  uint32_t eyeCount = fs.stereoIpd ? 2 : 1;
  std::array<Camera, 2> eyes = fs.stereoIpd ? stereoEyes(s.camera, *fs.stereoIpd) : std::array{s.camera, s.camera};
  Impl& d = *impl_;
  d.retired.completed(slot); // a slot is recorded again only after its previous frame completed
  d.recorded[slot] = false;
  d.ensureTargets(s.width * eyeCount, s.height);
  d.eyeWidth = s.width;

  // Per eye its frame, with clip planes from its own position as a mono render of it has.
  sio::FrameData fd[2] = {};
  for (uint32_t e = 0; e < eyeCount; ++e) {
    fd[e].camera = viewFrame(withClipPlanes(eyes[e], worldBounds_), s.width, s.height);
    fd[e].lightDir = glm::vec4(glm::normalize(s.lightDirection), s.lightIntensity);
    fd[e].skyAmbient = glm::vec4(s.skyAmbient, 0.0f);
    fd[e].groundAmbient = glm::vec4(s.groundAmbient, 0.0f);
    fd[e].lightAddress = d.lights.address();
    fd[e].lightCount = d.lightCount;
  }
  std::memcpy(d.frames[slot].mapped(), fd, eyeCount * sizeof(sio::FrameData));

  FrameStats& stats = d.slotStats[slot];
  stats = {};
  GpuTimer& timer = d.timers[slot];
  PipelineStatsQuery& pipelineStats = d.stats[slot];
  // barriers: the first orders this frame after all work submitted before it (the targets and the
  // lists are shared by the slots); the colour target ends in GENERAL, its writes visible to
  // compute shaders and transfers (colorTarget(); readbackImage).
  timer.cmdReset(cmd);
  pipelineStats.cmdReset(cmd);
  // A new visible set's indices, copied before the barrier that orders them before the draws.
  if (!d.visible.pendingCopies.empty()) {
    vkCmdCopyBuffer(cmd, d.indices.handle(), d.visible.indices.handle(), uint32_t(d.visible.pendingCopies.size()),
                    d.visible.pendingCopies.data());
    d.visible.pendingCopies.clear();
  }
  cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                   VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                   VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
  d.prepareTransparency(cmd, fs, slot, fd[0].camera.view);
  d.writeResolveSet(slot, fs.oit); // before any command binds it
  uint32_t frameTime = timer.cmdBegin(cmd, "frame");
  uint32_t clearTime = timer.cmdBegin(cmd, "clear");
  d.cmdClearTargets(cmd, slot, s.background);
  timer.cmdEnd(cmd, clearTime);
  pipelineStats.cmdBegin(cmd);

  VkRenderingAttachmentInfo colorAtt{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  colorAtt.imageView = d.color.view();
  colorAtt.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  colorAtt.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD; // cleared by cmdClearTargets
  colorAtt.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  VkRenderingAttachmentInfo depthAtt{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  depthAtt.imageView = d.depth.view();
  depthAtt.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
  depthAtt.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;    // cleared to far (0: reverse-Z) by cmdClearTargets
  depthAtt.storeOp = VK_ATTACHMENT_STORE_OP_STORE; // the transparency passes test against it
  VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
  ri.renderArea = {{0, 0}, {d.colorWidth, s.height}};
  ri.layerCount = 1;
  ri.colorAttachmentCount = 1;
  ri.pColorAttachments = &colorAtt;
  ri.pDepthAttachment = &depthAtt;
  vkCmdBeginRendering(cmd, &ri);

  VkDeviceSize zero = 0;
  VkBuffer vb = d.vertices.handle();
  vkCmdBindVertexBuffers(cmd, 0, 1, &vb, &zero);
  // Opaque and alpha-masked geometry: the whole scene, or the visible set's draws.
  const bool subset = d.visible.active;
  vkCmdBindIndexBuffer(cmd, subset ? d.visible.indices.handle() : d.indices.handle(), 0, VK_INDEX_TYPE_UINT32);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, d.layout, 0, 1, &d.descriptors.set, 0, nullptr);
  const VkDeviceAddress instances = subset ? d.visible.instances.address() : d.instanceBuffer.address();
  uint32_t opaqueTime = timer.cmdBegin(cmd, "opaque");
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, d.opaquePipeline);
  for (uint32_t e = 0; e < eyeCount; ++e) {
    VkDeviceAddress frame = d.cmdSetEye(cmd, slot, e);
    for (const ForwardBatch& b : subset ? d.visible.batches : d.batches)
      d.cmdDraw(cmd, frame, instances, b.range, b.mirrored, b.firstInstance, b.instanceCount, stats);
  }
  timer.cmdEnd(cmd, opaqueTime);
  vkCmdEndRendering(cmd);

  // Blended geometry (forward_oit.cpp), which leaves the colour in GENERAL.
  d.cmdTransparency(cmd, fs, slot, eyeCount, stats);
  pipelineStats.cmdEnd(cmd);
  timer.cmdEnd(cmd, frameTime);
  d.recorded[slot] = true;
  return Ok{};
}

Result<RenderOutput> ForwardRenderer::collect(uint32_t slot) {
  Impl& d = *impl_;
  if (slot >= kMaxFramesInFlight || !d.recorded[slot])
    return Error{fmt::format("frame slot {} holds no recorded frame", slot)};
  RenderOutput out;
  out.stats = d.slotStats[slot];
  out.stats.passTimes = d.timers[slot].read();
  out.stats.pipeline = d.stats[slot].read();
  if (d.slotOit[slot])
    out.stats.oit =
        oitStats(*reinterpret_cast<const sio::OitCounters*>(d.oitReadback[slot].mapped()), d.oitNodeCapacity);
  d.recorded[slot] = false;
  d.retired.completed(slot);
  return out;
}

const gpu::Image& ForwardRenderer::colorTarget() const { return impl_->color; }

Status ForwardRenderer::setVisibleTriangles(const std::vector<uint32_t>* sortedIds) {
  Impl& d = *impl_;
  ForwardVisibleSet next;
  if (sortedIds) {
    const std::vector<uint32_t>& ids = *sortedIds;
    uint64_t total = 0;
    for (const Instance& inst : d.sceneInstances)
      if (inst.mesh < d.meshes.size()) total += d.meshes[inst.mesh].indexCount / 3;
    if (std::adjacent_find(ids.begin(), ids.end(), std::greater_equal<uint32_t>()) != ids.end())
      return Error{"visible triangle IDs are not sorted and unique"};
    if (!ids.empty() && ids.back() >= total)
      return Error{fmt::format("visible triangle {} is outside the scene's {} triangles", ids.back(), total)};
    next.active = true;
    std::vector<sio::GpuInstance> instanceData;
    uint64_t begin = 0, indexCount = 0; // the instance's first global triangle ID; indices so far
    uint32_t blendInstance = 0;         // BLEND instances so far (blendInstances' order)
    size_t k = 0;
    for (const Instance& inst : d.sceneInstances) {
      if (inst.mesh >= d.meshes.size()) continue;
      const ForwardMeshRange& m = d.meshes[inst.mesh];
      const bool blend = d.isBlend(inst.mesh);
      uint64_t end = begin + m.indexCount / 3;
      ForwardBlendRange listed{blendInstance, {inst.mesh, uint32_t(indexCount), 0}, {}};
      while (k < ids.size() && ids[k] < end) { // one copy per run of consecutive triangles
        size_t run = 1;
        while (k + run < ids.size() && ids[k + run] == ids[k] + run && ids[k + run] < end) ++run;
        next.pendingCopies.push_back({(m.firstIndex + (ids[k] - begin) * 3) * 4, indexCount * 4, run * 12});
        if (blend)
          for (size_t i = 0; i < run; ++i) listed.triangles.push_back(uint32_t(ids[k] - begin + i));
        indexCount += run * 3;
        k += run;
      }
      begin = end;
      blendInstance += blend;
      if (indexCount > UINT32_MAX) return Error{"visible triangles exceed 32-bit index ranges"};
      listed.range.indexCount = uint32_t(indexCount - listed.range.firstIndex);
      if (listed.range.indexCount == 0) continue;
      if (blend) {
        next.blend.push_back(std::move(listed));
      } else {
        next.batches.push_back({listed.range, isMirrored(inst.transform), uint32_t(instanceData.size()), 1});
        instanceData.push_back(makeGpuInstance(inst.transform));
      }
    }
    next.indices = createBuffer(d.ctx, std::max<uint64_t>(indexCount, 1) * 4,
                                VK_BUFFER_USAGE_INDEX_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                MemoryUsage::GpuOnly, "visible indices");
    next.instances = createBuffer(d.ctx, std::max<size_t>(instanceData.size(), 1) * sizeof(sio::GpuInstance),
                                  VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::Upload, "visible instances");
    if (!instanceData.empty())
      std::memcpy(next.instances.mapped(), instanceData.data(), instanceData.size() * sizeof(sio::GpuInstance));
  }
  // Frames recorded and not yet collected may still draw the replaced set.
  d.retired.retire(std::move(d.visible.indices), d.inFlight());
  d.retired.retire(std::move(d.visible.instances), d.inFlight());
  d.visible = std::move(next);
  return Ok{};
}

Result<RenderOutput> ForwardRenderer::render(const ForwardRenderSettings& fs) {
  Impl& d = *impl_;
  if (Status st = checkSettings(fs); !st) return st.error(); // nothing submitted
  Status recorded = Ok{};
  d.ctx.submitAndWait([&](VkCommandBuffer cmd) { recorded = record(cmd, fs, 0); });
  if (!recorded) return recorded.error();
  auto out = collect(0);
  if (!out || !fs.base.readImage) return out;
  std::vector<uint8_t> raw = readbackImage(d.ctx, d.color, VK_IMAGE_LAYOUT_GENERAL, 8);
  convertHalfImage(raw, d.colorWidth, d.height, fs.base.readLinear, *out);
  return out;
}

} // namespace mirage::render
