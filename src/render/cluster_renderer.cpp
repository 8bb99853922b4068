// ClusterRenderer: pipelines and the per-frame command sequence (docs/render.md, "Passes").
#include <algorithm>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "cluster_impl.h"
#include "render_util.h"
#include "mirage/gpu/commands.h"
#include "mirage/gpu/descriptors.h"
#include "mirage/gpu/pipeline.h"
#include "mirage/gpu/shaders.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

namespace {

constexpr VkFormat kColorFormat = VK_FORMAT_R16G16B16A16_SFLOAT; // as the forward renderer
constexpr VkFormat kVisFormat = VK_FORMAT_R32G32_UINT;           // (visible index + 1, triangle)
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
// Visible-cluster entries: the instanced cluster count, capped so the buffer stays 32 MiB.
constexpr uint64_t kMaxVisibleClusters = 4u << 20;

// World-space frustum planes (Gribb-Hartmann) of a reverse-Z projection: clip-space inside is
// -w <= x, y <= w and z <= w (near); the far plane is left out (the camera's far bound is loose).
void frustumPlanes(const glm::mat4& m, glm::vec4* planes) {
  auto row = [&](int r) { return glm::vec4(m[0][r], m[1][r], m[2][r], m[3][r]); };
  glm::vec4 p[5] = {row(3) + row(0), row(3) - row(0), row(3) + row(1), row(3) - row(1), row(3) - row(2)};
  for (int i = 0; i < 5; ++i) planes[i] = p[i] / glm::length(glm::vec3(p[i]));
}

} // namespace

const char* toString(RasterBackend b) {
  switch (b) {
  case RasterBackend::Auto:
    return "auto";
  case RasterBackend::Mesh:
    return "mesh";
  case RasterBackend::Indirect:
    return "indirect";
  case RasterBackend::Compute:
    return "compute";
  }
  return "?";
}

Result<RasterBackend> parseRasterBackend(std::string_view text) {
  for (RasterBackend b : {RasterBackend::Auto, RasterBackend::Mesh, RasterBackend::Indirect, RasterBackend::Compute})
    if (text == toString(b)) return b;
  return Error{fmt::format("--raster '{}': expected auto, mesh, indirect or compute", text)};
}

struct ClusterRenderer::Impl {
  Context& ctx;
  ClusterSceneData scene;
  Buffer frame, visibleInstances, visible, counters, visBuffer;
  DescriptorSet descriptors; // material textures, the visibility image, the colour target
  Unique<VkPipelineLayout> layout;
  Unique<VkPipeline> cullPipeline, selectPipeline, argsPipeline, rasterPipeline, meshPipeline, indirectPipeline,
      resolvePipeline;
  VkShaderStageFlags pushStages = 0;
  Image color, vis, depth;
  uint32_t width = 0, height = 0, visibleCapacity = 0;
  GpuTimer timer;

  Impl(Context& c, ClusterSceneData s) : ctx(c), scene(std::move(s)), timer(c) {}
  void createDescriptors();
  void createPipelines();
  void ensureTargets(uint32_t w, uint32_t h);
  sio::ClusterPush push() const;
  void cmdSelect(VkCommandBuffer cmd, const sio::ClusterPush& p);
  void cmdRasterize(VkCommandBuffer cmd, const sio::ClusterPush& p, RasterBackend backend);
  void cmdResolve(VkCommandBuffer cmd, const sio::ClusterPush& p);
};

void ClusterRenderer::Impl::createDescriptors() {
  // Textures and the visibility image are read by the resolve (compute); binding 2 is its output.
  VkDescriptorSetLayoutBinding bindings[] = {
      {0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, uint32_t(scene.textures.size()), VK_SHADER_STAGE_COMPUTE_BIT,
       nullptr},
      {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
      {2, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr}};
  descriptors = createDescriptorSet(ctx, bindings);
  std::vector<VkDescriptorImageInfo> infos;
  for (const Image& img : scene.textures)
    infos.push_back({scene.sampler, img.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL});
  writeImageDescriptors(ctx, descriptors.set, 0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, infos);
}

void ClusterRenderer::Impl::createPipelines() {
  pushStages = VK_SHADER_STAGE_COMPUTE_BIT | VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;
  if (ctx.caps().meshShader) pushStages |= VK_SHADER_STAGE_MESH_BIT_EXT;
  layout = createPipelineLayout(ctx, {descriptors.layout.get()}, sizeof(sio::ClusterPush), pushStages);
  cullPipeline = createComputePipeline(ctx, "cluster_cull.comp", layout);
  selectPipeline = createComputePipeline(ctx, "cluster_select.comp", layout);
  argsPipeline = createComputePipeline(ctx, "cluster_args.comp", layout);
  if (ctx.caps().int64BufferAtomics) rasterPipeline = createComputePipeline(ctx, "cluster_raster.comp", layout);
  GraphicsPipelineDesc d;
  if (ctx.caps().meshShader) {
    GraphicsPipelineDesc m;
    m.meshShader = "cluster_vis.mesh";
    m.fragmentShader = "cluster_vis_mesh.frag";
    m.layout = layout;
    m.colorFormats = {kVisFormat};
    m.depthFormat = kDepthFormat;
    meshPipeline = createGraphicsPipeline(ctx, m);
  }
  d.vertexShader = "cluster_vis.vert";
  d.fragmentShader = "cluster_vis.frag";
  d.layout = layout;
  d.colorFormats = {kVisFormat};
  d.depthFormat = kDepthFormat;
  indirectPipeline = createGraphicsPipeline(ctx, d);
  resolvePipeline = createComputePipeline(ctx, "cluster_resolve.comp", layout);

  constexpr VkBufferUsageFlags kStorage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  visibleCapacity = uint32_t(std::clamp<uint64_t>(scene.instancedClusters, 1, kMaxVisibleClusters));
  frame = createBuffer(ctx, sizeof(sio::ClusterFrame), kStorage, MemoryUsage::Upload, "cluster frame");
  visibleInstances = createBuffer(ctx, scene.instanceCount * uint64_t(sizeof(sio::VisibleInstance)), kStorage,
                                  MemoryUsage::GpuOnly, "visible instances");
  // Zeroed once: entry 0 is then always a valid (instance, cluster) pair, which the resolve reads
  // for background pixels too (see cluster_resolve.comp).
  std::vector<sio::VisibleCluster> zeros(visibleCapacity, sio::VisibleCluster{0, 0});
  visible = createBufferWithData<sio::VisibleCluster>(ctx, zeros, kStorage, "visible clusters");
  counters = createBuffer(ctx, sizeof(sio::ClusterCounters),
                          kStorage | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                              VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                          MemoryUsage::GpuOnly, "cluster counters");
}

void ClusterRenderer::Impl::ensureTargets(uint32_t w, uint32_t h) {
  if (w == width && h == height) return;
  color = createImage2D(ctx, w, h, kColorFormat, VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT, "color");
  vis = createImage2D(ctx, w, h, kVisFormat, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT,
                      "visibility");
  depth = createImage2D(ctx, w, h, kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, "visibility depth");
  visBuffer =
      createBuffer(ctx, uint64_t(w) * h * 8, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                   MemoryUsage::GpuOnly, "visibility64");
  VkDescriptorImageInfo visInfo{scene.nearestSampler, vis.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  VkDescriptorImageInfo colorInfo{VK_NULL_HANDLE, color.view(), VK_IMAGE_LAYOUT_GENERAL};
  writeImageDescriptors(ctx, descriptors.set, 1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, {&visInfo, 1});
  writeImageDescriptors(ctx, descriptors.set, 2, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, {&colorInfo, 1});
  width = w;
  height = h;
}

sio::ClusterPush ClusterRenderer::Impl::push() const {
  sio::ClusterPush p{};
  p.frameAddress = frame.address();
  p.clusterAddress = scene.clusters.address();
  p.vertexAddress = scene.vertices.address();
  p.clusterVertexAddress = scene.clusterVertices.address();
  p.indexAddress = scene.indices.address();
  p.meshAddress = scene.meshes.address();
  p.instanceAddress = scene.instances.address();
  p.materialAddress = scene.materials.address();
  p.visibleInstanceAddress = visibleInstances.address();
  p.levelAddress = scene.levels.address();
  p.visibleAddress = visible.address();
  p.counterAddress = counters.address();
  p.visBufferAddress = visBuffer.address();
  p.maxMeshClusters = scene.maxMeshClusters;
  return p;
}

// barriers: on entry the counters were zeroed by a transfer and made visible to compute; on exit
// the visible-cluster list and every indirect argument are written and visible to the indirect,
// mesh, vertex, fragment and compute stages.
void ClusterRenderer::Impl::cmdSelect(VkCommandBuffer cmd, const sio::ClusterPush& p) {
  constexpr VkAccessFlags2 kRW = VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
  constexpr VkPipelineStageFlags2 kCS = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
  vkCmdPushConstants(cmd, layout, pushStages, 0, sizeof(p), &p);
  // Per-instance culling first: the cluster pass only visits clusters of visible instances.
  uint32_t slot = timer.cmdBegin(cmd, "cull", kCS);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, cullPipeline);
  vkCmdDispatch(cmd, (scene.instanceCount + MIRAGE_CLUSTER_WORKGROUP - 1) / MIRAGE_CLUSTER_WORKGROUP, 1, 1);
  timer.cmdEnd(cmd, slot, kCS);
  cmdMemoryBarrier(cmd, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | kCS,
                   VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | kRW);
  // LOCALCUT + frustum over every (visible instance, cluster): a flat pass, one thread each.
  slot = timer.cmdBegin(cmd, "select", kCS);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, selectPipeline);
  vkCmdDispatchIndirect(cmd, counters.handle(), offsetof(sio::ClusterCounters, selectArgs));
  timer.cmdEnd(cmd, slot, kCS);
  cmdMemoryBarrier(cmd, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCS, kRW);
  // Raster arguments from the visible count (one thread).
  VkPipelineStageFlags2 meshStage = ctx.caps().meshShader ? VK_PIPELINE_STAGE_2_MESH_SHADER_BIT_EXT : 0;
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, argsPipeline);
  vkCmdDispatch(cmd, 1, 1, 1);
  cmdMemoryBarrier(cmd, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | meshStage | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT |
                       VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | kCS | VK_PIPELINE_STAGE_2_COPY_BIT,
                   VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT |
                       VK_ACCESS_2_TRANSFER_READ_BIT);
}

// barriers: cmdSelect's outputs visible; the 64-bit visibility buffer zeroed and visible to compute
// (compute backend). On exit the visibility image is in SHADER_READ_ONLY_OPTIMAL and whatever the
// backend wrote is visible to the resolve (a compute shader).
void ClusterRenderer::Impl::cmdRasterize(VkCommandBuffer cmd, const sio::ClusterPush& p, RasterBackend backend) {
  uint32_t slot = timer.cmdBegin(cmd, "raster");
  vkCmdPushConstants(cmd, layout, pushStages, 0, sizeof(p), &p);
  ImageBarrier toRead{vis.handle(),
                      VK_PIPELINE_STAGE_2_NONE,
                      0,
                      VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                      VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
                      VK_IMAGE_LAYOUT_UNDEFINED,
                      VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  if (backend == RasterBackend::Compute) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, rasterPipeline);
    vkCmdDispatchIndirect(cmd, counters.handle(), offsetof(sio::ClusterCounters, rasterArgs));
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
    cmdImageBarrier(cmd, toRead); // unused by the resolve here, but the descriptor must be valid
    timer.cmdEnd(cmd, slot);
    return;
  }
  ImageBarrier toAttachment[] = {
      {vis.handle(), VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, 0, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
       VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL},
      {depth.handle(), VK_PIPELINE_STAGE_2_NONE, 0,
       VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT,
       VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT,
       VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_ASPECT_DEPTH_BIT}};
  cmdImageBarriers(cmd, toAttachment);
  VkRenderingAttachmentInfo visAtt{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  visAtt.imageView = vis.view();
  visAtt.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  visAtt.loadOp = VK_ATTACHMENT_LOAD_OP_CLEAR; // 0 = no cluster
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
  VkViewport vp{0.0f, 0.0f, float(width), float(height), 0.0f, 1.0f};
  VkRect2D scissor{{0, 0}, {width, height}};
  vkCmdSetViewport(cmd, 0, 1, &vp);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
  // Facing is decided per instance in the fragment shader (single/double-sided, mirrored), so one
  // draw serves every material.
  vkCmdSetCullMode(cmd, VK_CULL_MODE_NONE);
  vkCmdSetFrontFace(cmd, VK_FRONT_FACE_COUNTER_CLOCKWISE);
  if (backend == RasterBackend::Mesh) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, meshPipeline);
    vkCmdDrawMeshTasksIndirectEXT(cmd, counters.handle(), offsetof(sio::ClusterCounters, rasterArgs), 1,
                                  sizeof(VkDrawMeshTasksIndirectCommandEXT));
  } else {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, indirectPipeline);
    vkCmdDrawIndirect(cmd, counters.handle(), offsetof(sio::ClusterCounters, drawArgs), 1,
                      sizeof(VkDrawIndirectCommand));
  }
  vkCmdEndRendering(cmd);
  toRead.srcStage = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
  toRead.srcAccess = VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT;
  toRead.oldLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  cmdImageBarrier(cmd, toRead);
  timer.cmdEnd(cmd, slot);
}

// barriers: cmdRasterize's output visible to compute shaders. The color target ends in GENERAL with
// the resolve's writes available, which the readback expects.
void ClusterRenderer::Impl::cmdResolve(VkCommandBuffer cmd, const sio::ClusterPush& p) {
  uint32_t slot = timer.cmdBegin(cmd, "resolve");
  cmdImageBarrier(cmd, {color.handle(), VK_PIPELINE_STAGE_2_NONE, 0, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                        VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL});
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, resolvePipeline);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &descriptors.set, 0, nullptr);
  vkCmdPushConstants(cmd, layout, pushStages, 0, sizeof(p), &p);
  vkCmdDispatch(cmd, (width + 7) / 8, (height + 7) / 8, 1); // 8x8 pixels per workgroup
  timer.cmdEnd(cmd, slot);
}

ClusterRenderer::ClusterRenderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ClusterRenderer::~ClusterRenderer() = default;
const Bounds& ClusterRenderer::worldBounds() const { return impl_->scene.worldBounds; }
uint64_t ClusterRenderer::clusterCount() const { return impl_->scene.clusterCount; }

Result<std::unique_ptr<ClusterRenderer>> ClusterRenderer::create(Context& context, const lod::LodAsset& asset) {
  auto data = uploadClusterScene(context, asset);
  if (!data) return data.error();
  auto impl = std::make_unique<Impl>(context, std::move(*data));
  impl->createDescriptors();
  impl->createPipelines();
  return std::unique_ptr<ClusterRenderer>(new ClusterRenderer(std::move(impl)));
}

Result<ClusterRenderOutput> ClusterRenderer::render(const ClusterRenderSettings& cs) {
  const RenderSettings& s = cs.base;
  if (s.width == 0 || s.height == 0 || s.width > kMaxRenderDimension || s.height > kMaxRenderDimension)
    return Error{fmt::format("render size {}x{} is outside 1..{}", s.width, s.height, kMaxRenderDimension)};
  if (!(cs.tauPixels > 0.0f)) return Error{fmt::format("--tau {} must be a positive number of pixels", cs.tauPixels)};
  Impl& d = *impl_;
  const DeviceCapabilities& caps = d.ctx.caps();
  RasterBackend backend =
      cs.raster == RasterBackend::Auto ? (caps.meshShader ? RasterBackend::Mesh : RasterBackend::Indirect) : cs.raster;
  if (backend == RasterBackend::Mesh && !caps.meshShader)
    return Error{"--raster mesh: the device has no VK_EXT_mesh_shader"};
  if (backend == RasterBackend::Compute && !caps.int64BufferAtomics)
    return Error{"--raster compute: the device has no 64-bit buffer atomics"};
  d.ensureTargets(s.width, s.height);

  Camera cam = withClipPlanes(s.camera, d.scene.worldBounds);
  glm::mat4 proj = cam.projection(float(s.width) / float(s.height));
  sio::ClusterFrame f{};
  f.viewProj = proj * cam.view();
  f.invViewProj = glm::inverse(f.viewProj);
  f.eye = glm::vec4(cam.eye, 1.0f);
  frustumPlanes(f.viewProj, f.planes);
  f.lightDir = glm::vec4(glm::normalize(s.lightDirection), s.lightIntensity);
  f.skyAmbient = glm::vec4(s.skyAmbient, 0.0f);
  f.groundAmbient = glm::vec4(s.groundAmbient, 0.0f);
  f.viewport = {float(s.width), float(s.height)};
  f.znear = cam.znear;
  f.errorScale = std::abs(proj[1][1]) * 0.5f * float(s.height);
  f.tau = cs.tauPixels;
  f.flags = (cs.flagBackFaces ? MIRAGE_FRAME_FLAG_BACKFACES : 0u) |
            (cs.frustumCulling ? MIRAGE_FRAME_FRUSTUM_CULL : 0u) |
            (backend == RasterBackend::Compute ? MIRAGE_FRAME_SOURCE_BUFFER : 0u);
  f.visibleCapacity = d.visibleCapacity;
  f.instanceCount = d.scene.instanceCount;
  f.background = s.background;
  std::memcpy(d.frame.mapped(), &f, sizeof(f));
  sio::ClusterPush p = d.push();

  // barriers: none on entry (the previous frame completed: one-shot submits wait), beyond ordering
  // this frame's clears after any earlier use of the same buffers.
  d.ctx.submitAndWait([&](VkCommandBuffer cmd) {
    d.timer.cmdReset(cmd);
    uint32_t frameSlot = d.timer.cmdBegin(cmd, "frame");
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                     VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                     VK_ACCESS_2_TRANSFER_WRITE_BIT);
    vkCmdFillBuffer(cmd, d.counters.handle(), 0, VK_WHOLE_SIZE, 0);
    if (backend == RasterBackend::Compute) vkCmdFillBuffer(cmd, d.visBuffer.handle(), 0, VK_WHOLE_SIZE, 0);
    // Shaders reach the counters through buffer addresses, which synchronization validation does
    // not track: make the clears visible to the indirect reads directly, not only through the
    // compute passes' chained barriers.
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT |
                         VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT);
    d.cmdSelect(cmd, p);             // instance cull, LOCALCUT + frustum, raster args
    d.cmdRasterize(cmd, p, backend); // visibility: (cluster, triangle) per pixel
    d.cmdResolve(cmd, p);            // fetch, interpolate, shade
    d.timer.cmdEnd(cmd, frameSlot);
  });

  ClusterRenderOutput out;
  out.image.stats.passTimes = d.timer.read();
  sio::ClusterCounters c{};
  std::vector<uint8_t> raw = readbackBuffer(d.ctx, d.counters, sizeof(c));
  std::memcpy(&c, raw.data(), sizeof(c));
  out.stats.instancesVisible = c.visibleInstances;
  out.stats.clustersTested = c.clustersTested;
  out.stats.clustersSelected = std::min(c.visibleClusters, d.visibleCapacity);
  out.stats.clustersFrustumCulled = c.clustersFrustumCulled;
  out.stats.clustersOverflow = c.clustersOverflow;
  out.stats.trianglesRasterized = c.trianglesSelected;
  out.stats.raster = backend;
  out.image.stats.drawCalls = 1;
  out.image.stats.trianglesSubmitted = c.trianglesSelected;

  std::vector<uint8_t> img = readbackImage(d.ctx, d.color, VK_IMAGE_LAYOUT_GENERAL, 8);
  convertHalfImage(img, s.width, s.height, s.readLinear, out.image);
  return out;
}

} // namespace mirage::render
