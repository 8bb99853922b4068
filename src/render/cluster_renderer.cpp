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
// Transparency node pool: this many blended fragments per pixel on average (12 bytes each), capped
// by the device's storage-buffer range; excess fragments are dropped and counted.
constexpr uint64_t kOitNodesPerPixel = 4;

// World-space frustum planes (Gribb-Hartmann) of a reverse-Z projection: clip-space inside is
// -w <= x, y <= w and z <= w (near); the far plane is left out (the camera's far bound is loose).
void frustumPlanes(const glm::mat4& m, glm::vec4* planes) {
  auto row = [&](int r) { return glm::vec4(m[0][r], m[1][r], m[2][r], m[3][r]); };
  glm::vec4 p[5] = {row(3) + row(0), row(3) - row(0), row(3) + row(1), row(3) - row(1), row(3) - row(2)};
  for (int i = 0; i < 5; ++i) planes[i] = p[i] / glm::length(glm::vec3(p[i]));
}

constexpr VkPipelineStageFlags2 kCS = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;

// Every pass reaches its buffers through device addresses, which synchronization validation does
// not track, so each phase boundary is one conservative global barrier: whatever compute, fragment
// or transfer work wrote is visible to every later indirect read, shader access and transfer.
void cmdPhaseBarrier(VkCommandBuffer cmd, bool meshShaders) {
  VkPipelineStageFlags2 mesh = meshShaders ? VK_PIPELINE_STAGE_2_MESH_SHADER_BIT_EXT : 0;
  cmdMemoryBarrier(cmd, kCS | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                   VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | kCS | mesh | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT |
                       VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                   VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT |
                       VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_TRANSFER_READ_BIT |
                       VK_ACCESS_2_TRANSFER_WRITE_BIT);
}

// Byte offsets of one raster pass's indirect arguments in ClusterCounters.
VkDeviceSize listArgsOffset(uint32_t pass, uint32_t list) {
  return offsetof(sio::ClusterCounters, lists) + (pass * 2 + list) * sizeof(sio::ClusterListArgs);
}
VkDeviceSize dispatchArgsOffset(uint32_t pass, uint32_t list) {
  return listArgsOffset(pass, list) + offsetof(sio::ClusterListArgs, dispatch);
}
VkDeviceSize drawArgsOffset(uint32_t pass, uint32_t list) {
  return listArgsOffset(pass, list) + offsetof(sio::ClusterListArgs, draw);
}

} // namespace

const char* toString(RasterBackend b) { return nameOf(kRasterBackendNames, b); }
Result<RasterBackend> parseRasterBackend(std::string_view text) {
  return parseNamed(text, "--raster", kRasterBackendNames);
}
const char* toString(BlendRaster b) { return nameOf(kBlendRasterNames, b); }
Result<BlendRaster> parseBlendRaster(std::string_view text) {
  return parseNamed(text, "--blend-raster", kBlendRasterNames);
}
const char* toString(SelectionMode m) { return nameOf(kSelectionModeNames, m); }
Result<SelectionMode> parseSelectionMode(std::string_view text) {
  return parseNamed(text, "--selection", kSelectionModeNames);
}

struct ClusterRenderer::Impl {
  Context& ctx;
  ClusterSceneData scene;
  Buffer frame, visibleInstances, lateInstances, visible, counters, visBuffer, candidates, history, hzb;
  Buffer fade, surfelLink;                 // mixed scenes: per-instance fade, ClusterSurfelLink (created on first use)
  Buffer traversal, queues[2];             // hierarchical selection: counters / indirect arguments, node queues
  Buffer blendVisible, oitHeads, oitNodes; // alpha BLEND: own cluster list, per-pixel fragment lists
  DescriptorSet descriptors;               // material textures, the visibility image, the colour target, depth
  Buffer pvsInstances, pvsClusters;        // the camera cell's cluster PVS (setPvs); empty: no PVS culling
  Unique<VkPipelineLayout> layout;
  Unique<VkPipeline> cullPipeline, selectPipeline, traversePipeline, argsPipeline, rasterPipeline, rasterMaskPipeline,
      meshPipeline, indirectPipeline, meshAtomicPipeline, indirectAtomicPipeline, occlusionPipeline,
      instanceOcclusionPipeline, hzbPipeline, resolvePipeline, blendRasterPipeline, compositePipeline;
  // Hardware blend raster, created on first use: mesh / indirect, and the buffer backends' depth copy.
  Unique<VkPipeline> blendMeshPipeline, blendIndirectPipeline, blendDepthPipeline;
  VkShaderStageFlags pushStages = 0;
  Image color, vis, depth;
  uint32_t width = 0, height = 0, visibleCapacity = 0, hzbLevels = 0, queueCapacity = 0;
  uint32_t blendCapacity = 0, oitNodeCapacity = 0; // 0 without BLEND materials: no transparency passes
  uint32_t traversalDepth = 0; // deepest node of the tree this frame traverses (LOD BVH or DAG group tree)
  uint32_t hzbOffset[MIRAGE_HZB_MAX_LEVELS] = {};
  bool historyUsable = false; // the history bitmask fits (instance offsets below 2^32, buffer range)
  GpuTimer timer;

  Impl(Context& c, ClusterSceneData s) : ctx(c), scene(std::move(s)), timer(c, 48) {}
  void createDescriptors();
  void createPipelines();
  void ensureTargets(uint32_t w, uint32_t h);
  sio::ClusterPush push() const;
  void cmdPush(VkCommandBuffer cmd, sio::ClusterPush p, uint32_t rasterList);
  void cmdSelect(VkCommandBuffer cmd, const sio::ClusterPush& p, bool hierarchy);
  void cmdTraverse(VkCommandBuffer cmd, const sio::ClusterPush& p, uint32_t phase);
  void cmdArgs(VkCommandBuffer cmd, const sio::ClusterPush& p, uint32_t pass);
  void cmdRasterize(VkCommandBuffer cmd, const sio::ClusterPush& p, RasterBackend backend, uint32_t pass);
  void cmdHardwareList(VkCommandBuffer cmd, const sio::ClusterPush& p, RasterBackend backend, uint32_t pass,
                       bool atomic);
  void cmdBuildHzb(VkCommandBuffer cmd, const sio::ClusterPush& p);
  void cmdOcclusion(VkCommandBuffer cmd, const sio::ClusterPush& p, bool hierarchy);
  void cmdResolve(VkCommandBuffer cmd, const sio::ClusterPush& p);
  void cmdTransparency(VkCommandBuffer cmd, sio::ClusterPush p, BlendRaster blend, bool meshBlend, bool bufferTarget);
  void cmdBlendDepth(VkCommandBuffer cmd, const sio::ClusterPush& p, bool bufferTarget);
  void cmdBeginFullTarget(VkCommandBuffer cmd, VkRenderingInfo ri);
  void cmdDrawList(VkCommandBuffer cmd, bool mesh, uint32_t pass, uint32_t list);
  void cmdHardwareBlend(VkCommandBuffer cmd, const sio::ClusterPush& p, bool mesh);
  VkPipeline blendHardwarePipeline(bool mesh);
  bool hasBlend() const { return blendCapacity > 0; }
};

void ClusterRenderer::Impl::createDescriptors() {
  // Textures and the visibility image are read by the resolve (compute); the textures also by the
  // rasterizers' alpha test (compute and fragment); binding 2 is the resolve's output; binding 3 the
  // hardware backends' depth, read by the HZB build and the blend raster.
  VkDescriptorSetLayoutBinding bindings[] = {
      {0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, uint32_t(scene.textures.size()),
       VK_SHADER_STAGE_COMPUTE_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, nullptr},
      {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
      {2, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
      {3, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr}};
  descriptors = createDescriptorSet(ctx, bindings);
  std::vector<VkDescriptorImageInfo> infos;
  for (const Image& img : scene.textures)
    infos.push_back({scene.sampler, img.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL});
  writeImageDescriptors(ctx, descriptors.set, 0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, infos);
}

void ClusterRenderer::Impl::createPipelines() {
  const DeviceCapabilities& caps = ctx.caps();
  pushStages = VK_SHADER_STAGE_COMPUTE_BIT | VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;
  if (caps.meshShader) pushStages |= VK_SHADER_STAGE_MESH_BIT_EXT;
  layout = createPipelineLayout(ctx, {descriptors.layout.get()}, sizeof(sio::ClusterPush), pushStages);
  cullPipeline = createComputePipeline(ctx, "cluster_cull.comp", layout);
  selectPipeline = createComputePipeline(ctx, "cluster_select.comp", layout);
  traversePipeline = createComputePipeline(ctx, "cluster_traverse.comp", layout);
  argsPipeline = createComputePipeline(ctx, "cluster_args.comp", layout);
  occlusionPipeline = createComputePipeline(ctx, "cluster_occlusion.comp", layout);
  instanceOcclusionPipeline = createComputePipeline(ctx, "cluster_instance_occlusion.comp", layout);
  hzbPipeline = createComputePipeline(ctx, "cluster_hzb.comp", layout);
  resolvePipeline = createComputePipeline(ctx, "cluster_resolve.comp", layout);
  if (caps.int64BufferAtomics) rasterPipeline = createComputePipeline(ctx, "cluster_raster.comp", layout);
  if (caps.int64BufferAtomics && scene.hasMask)
    rasterMaskPipeline = createComputePipeline(ctx, "cluster_raster_mask.comp", layout);
  if (scene.blendInstancedClusters > 0) {
    blendRasterPipeline = createComputePipeline(ctx, "cluster_raster_blend.comp", layout);
    compositePipeline = createComputePipeline(ctx, "cluster_oit_composite.comp", layout);
  }
  // Image backends: (visible entry + 1, triangle) into an R32G32 target, depth-tested. Hybrid's
  // hardware list: no attachments, the fragment shader does the compute rasterizer's atomicMax.
  auto graphics = [&](bool mesh, bool atomic) {
    GraphicsPipelineDesc d;
    (mesh ? d.meshShader : d.vertexShader) = mesh ? "cluster_vis.mesh" : "cluster_vis.vert";
    // Scenes with MASK materials take the *_mask variants (alpha test); others run no alpha code.
    std::string fragment = std::string(mesh ? (atomic ? "cluster_vis_mesh_atomic" : "cluster_vis_mesh")
                                            : (atomic ? "cluster_vis_atomic" : "cluster_vis")) +
                           (scene.hasMask ? "_mask.frag" : ".frag");
    d.fragmentShader = fragment;
    d.layout = layout;
    if (!atomic) {
      d.colorFormats = {kVisFormat};
      d.depthFormat = kDepthFormat;
    }
    return createGraphicsPipeline(ctx, d);
  };
  indirectPipeline = graphics(/*mesh=*/false, /*atomic=*/false);
  if (caps.meshShader) meshPipeline = graphics(/*mesh=*/true, /*atomic=*/false);
  if (caps.int64BufferAtomics && caps.fragmentStoresAndAtomics) {
    indirectAtomicPipeline = graphics(/*mesh=*/false, /*atomic=*/true);
    if (caps.meshShader) meshAtomicPipeline = graphics(/*mesh=*/true, /*atomic=*/true);
  }

  constexpr VkBufferUsageFlags kStorage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  visibleCapacity = uint32_t(std::clamp<uint64_t>(scene.instancedClusters, 1, kMaxVisibleClusters));
  frame = createBuffer(ctx, sizeof(sio::ClusterFrame), kStorage, MemoryUsage::Upload, "cluster frame");
  visibleInstances = createBuffer(ctx, scene.instanceCount * uint64_t(sizeof(sio::VisibleInstance)), kStorage,
                                  MemoryUsage::GpuOnly, "visible instances");
  lateInstances = createBuffer(ctx, scene.instanceCount * uint64_t(sizeof(sio::VisibleInstance)), kStorage,
                               MemoryUsage::GpuOnly, "late instances");
  // Zeroed once: entry 0 is then always a valid (instance, cluster) pair, which the resolve reads
  // for background pixels too (see cluster_resolve.comp).
  std::vector<sio::VisibleCluster> zeros(visibleCapacity, sio::VisibleCluster{0, 0});
  visible = createBufferWithData<sio::VisibleCluster>(ctx, zeros, kStorage, "visible clusters");
  if (scene.blendInstancedClusters > 0) { // zeroed: entry 0 is valid for every lane (as `visible`)
    blendCapacity = uint32_t(std::min<uint64_t>(scene.blendInstancedClusters, kMaxVisibleClusters));
    std::vector<sio::VisibleCluster> blendZeros(blendCapacity, sio::VisibleCluster{0, 0});
    blendVisible = createBufferWithData<sio::VisibleCluster>(ctx, blendZeros, kStorage, "blend clusters");
  }
  candidates = createBuffer(ctx, visibleCapacity * uint64_t(sizeof(sio::VisibleCluster)), kStorage,
                            MemoryUsage::GpuOnly, "occlusion candidates");
  counters = createBuffer(ctx, sizeof(sio::ClusterCounters),
                          kStorage | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                              VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                          MemoryUsage::GpuOnly, "cluster counters");
  // Traversal queues: one phase queues each (instance, node) at most once, and never more than fits
  // one dispatch row of workgroups.
  queueCapacity = uint32_t(std::clamp<uint64_t>(uint64_t(scene.instanceCount) * scene.maxMeshNodes, 64,
                                                uint64_t(MIRAGE_CLUSTER_DISPATCH_X) * MIRAGE_CLUSTER_WORKGROUP));
  for (Buffer& q : queues)
    q = createBuffer(ctx, queueCapacity * uint64_t(8), kStorage, MemoryUsage::GpuOnly, "selection queue");
  traversal = createBuffer(ctx, sizeof(sio::ClusterTraversal),
                           kStorage | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                               VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                           MemoryUsage::GpuOnly, "selection traversal");
  // One bit per (instance, cluster), then one per instance, zeroed: the first frame draws
  // everything in pass 2.
  uint64_t historyBits = scene.instancedClusters + scene.instanceCount;
  uint64_t historyBytes = (historyBits + 31) / 32 * 4;
  historyUsable = historyBits < (uint64_t(1) << 32) && historyBytes <= caps.maxStorageBufferRange;
  std::vector<uint32_t> noHistory(historyUsable ? historyBytes / 4 : 1, 0u);
  history = createBufferWithData<uint32_t>(
      ctx, noHistory, kStorage | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
      "visibility history"); // SRC: readOwnedClusters
}

void ClusterRenderer::Impl::ensureTargets(uint32_t w, uint32_t h) {
  if (w == width && h == height) return;
  color = createImage2D(ctx, w, h, kColorFormat, VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT, "color");
  vis = createImage2D(ctx, w, h, kVisFormat, VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT,
                      "visibility");
  depth = createImage2D(ctx, w, h, kDepthFormat,
                        VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT, "visibility depth");
  visBuffer =
      createBuffer(ctx, uint64_t(w) * h * 8, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                   MemoryUsage::GpuOnly, "visibility64");
  // HZB levels 1.. down to 1x1 (at least level 1) in one float buffer; level 0 would be the depth
  // itself, which the level-1 build reads directly.
  uint64_t floats = 0;
  hzbLevels = 1;
  for (uint32_t lw = (w + 1) / 2, lh = (h + 1) / 2; hzbLevels < MIRAGE_HZB_MAX_LEVELS;
       lw = (lw + 1) / 2, lh = (lh + 1) / 2) {
    hzbOffset[hzbLevels++] = uint32_t(floats);
    floats += uint64_t(lw) * lh;
    if (lw == 1 && lh == 1) break;
  }
  hzb = createBuffer(ctx, floats * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::GpuOnly, "hzb");
  if (hasBlend()) {
    uint64_t pixels = uint64_t(w) * h;
    oitHeads = createBuffer(ctx, pixels * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                            MemoryUsage::GpuOnly, "transparency heads");
    oitNodeCapacity = uint32_t(
        std::min<uint64_t>(pixels * kOitNodesPerPixel, ctx.caps().maxStorageBufferRange / sizeof(sio::OitNode)));
    oitNodes = createBuffer(ctx, uint64_t(oitNodeCapacity) * sizeof(sio::OitNode), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                            MemoryUsage::GpuOnly, "transparency nodes");
  }
  VkDescriptorImageInfo visInfo{scene.nearestSampler, vis.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  VkDescriptorImageInfo colorInfo{VK_NULL_HANDLE, color.view(), VK_IMAGE_LAYOUT_GENERAL};
  VkDescriptorImageInfo depthInfo{scene.nearestSampler, depth.view(), VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL};
  writeImageDescriptors(ctx, descriptors.set, 1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, {&visInfo, 1});
  writeImageDescriptors(ctx, descriptors.set, 2, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, {&colorInfo, 1});
  writeImageDescriptors(ctx, descriptors.set, 3, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, {&depthInfo, 1});
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

void ClusterRenderer::Impl::cmdPush(VkCommandBuffer cmd, sio::ClusterPush p, uint32_t rasterList) {
  p.rasterList = rasterList;
  vkCmdPushConstants(cmd, layout, pushStages, 0, sizeof(p), &p);
}

// barriers: on entry the counters were zeroed and the clears made visible (cmdPhaseBarrier); on
// exit the visible instances, pass-1 lists and occlusion candidates are written and visible.
void ClusterRenderer::Impl::cmdSelect(VkCommandBuffer cmd, const sio::ClusterPush& p, bool hierarchy) {
  cmdPush(cmd, p, 0);
  // Per-instance culling first: the cluster pass only visits clusters of visible instances.
  uint32_t slot = timer.cmdBegin(cmd, "cull", kCS);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, cullPipeline);
  vkCmdDispatch(cmd, (scene.instanceCount + MIRAGE_CLUSTER_WORKGROUP - 1) / MIRAGE_CLUSTER_WORKGROUP, 1, 1);
  timer.cmdEnd(cmd, slot, kCS);
  cmdPhaseBarrier(cmd, ctx.caps().meshShader);
  // LOCALCUT + frustum + cones: a flat pass over every (visible instance, cluster of its level
  // range), or the BVH traversal that visits only groups above the cut.
  slot = timer.cmdBegin(cmd, "select", kCS);
  if (hierarchy) {
    cmdTraverse(cmd, p, 0);
  } else {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, selectPipeline);
    vkCmdDispatchIndirect(cmd, counters.handle(), offsetof(sio::ClusterCounters, selectArgs));
  }
  timer.cmdEnd(cmd, slot, kCS);
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

// Dynamic rendering over the whole target with the state every cluster draw shares: full viewport
// and scissor, no culling and counter-clockwise fronts (facing is decided per instance in the
// fragment shaders: single/double-sided, mirrored, so one draw serves every material).
void ClusterRenderer::Impl::cmdBeginFullTarget(VkCommandBuffer cmd, VkRenderingInfo ri) {
  ri.renderArea = {{0, 0}, {width, height}};
  ri.layerCount = 1;
  vkCmdBeginRendering(cmd, &ri);
  cmdSetFullViewport(cmd, width, height);
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
// `atomic`, into the 64-bit buffer through fragment atomics with no attachments (hybrid).
// barriers: the pass's arguments visible; the images in the layouts cmdRasterize leaves them in.
void ClusterRenderer::Impl::cmdHardwareList(VkCommandBuffer cmd, const sio::ClusterPush& p, RasterBackend backend,
                                            uint32_t pass, bool atomic) {
  VkRenderingAttachmentInfo visAtt{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  visAtt.imageView = vis.view();
  visAtt.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
  visAtt.loadOp = pass == 0 ? VK_ATTACHMENT_LOAD_OP_CLEAR : VK_ATTACHMENT_LOAD_OP_LOAD; // 0 = no cluster
  visAtt.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
  VkRenderingAttachmentInfo depthAtt{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  depthAtt.imageView = depth.view();
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
  cmdBeginFullTarget(cmd, ri);
  cmdPush(cmd, p, pass * 2 + list);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout, 0, 1, &descriptors.set, 0, nullptr);
  bool mesh = backend == RasterBackend::Mesh;
  VkPipeline pipeline =
      mesh ? (atomic ? meshAtomicPipeline : meshPipeline) : (atomic ? indirectAtomicPipeline : indirectPipeline);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
  cmdDrawList(cmd, mesh, pass, list);
  vkCmdEndRendering(cmd);
}

// barriers: cmdArgs(pass) visible; the 64-bit buffer zeroed and visible (buffer backends). On exit
// the visibility image and depth are readable by compute shaders (SHADER_READ_ONLY /
// DEPTH_READ_ONLY; the buffer backends transition them unwritten so the descriptors stay valid)
// and every write of the pass is visible to the HZB build, the next pass and the resolve.
void ClusterRenderer::Impl::cmdRasterize(VkCommandBuffer cmd, const sio::ClusterPush& p, RasterBackend backend,
                                         uint32_t pass) {
  uint32_t slot = timer.cmdBegin(cmd, pass == 0 ? "raster" : "raster2");
  bool imageTarget = backend == RasterBackend::Mesh || backend == RasterBackend::Indirect;
  const VkPipelineStageFlags2 kDepthStages =
      VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
  const VkAccessFlags2 kDepthAccess =
      VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
  ImageBarrier toRead[] = {{vis.handle(), VK_PIPELINE_STAGE_2_NONE, 0, kCS, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
                            VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL},
                           {depth.handle(), VK_PIPELINE_STAGE_2_NONE, 0, kCS, VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
                            VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL,
                            VK_IMAGE_ASPECT_DEPTH_BIT}};
  if (imageTarget) {
    // Pass 0 starts from nothing; pass 1 keeps pass 0's ids and depth (read by the HZB since).
    ImageBarrier toAttachment[] = {
        {vis.handle(), pass == 0 ? VK_PIPELINE_STAGE_2_NONE : kCS, 0, VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
         VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
         pass == 0 ? VK_IMAGE_LAYOUT_UNDEFINED : VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL,
         VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL},
        {depth.handle(), pass == 0 ? VK_PIPELINE_STAGE_2_NONE : kCS, 0, kDepthStages, kDepthAccess,
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
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, rasterPipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &descriptors.set, 0, nullptr);
    vkCmdDispatchIndirect(cmd, counters.handle(), dispatchArgsOffset(pass, MIRAGE_LIST_UP));
    if (rasterMaskPipeline) { // masked clusters of the same list (the opaque kernel skipped them)
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, rasterMaskPipeline);
      vkCmdDispatchIndirect(cmd, counters.handle(), dispatchArgsOffset(pass, MIRAGE_LIST_UP));
    }
    if (backend == RasterBackend::Hybrid)
      cmdHardwareList(cmd, p, meshAtomicPipeline ? RasterBackend::Mesh : RasterBackend::Indirect, pass,
                      /*atomic=*/true);
    if (pass == 0) cmdImageBarriers(cmd, toRead); // unwritten, but the descriptors must be valid
  }
  cmdPhaseBarrier(cmd, ctx.caps().meshShader);
  timer.cmdEnd(cmd, slot);
}

// barriers: the raster pass's depth visible to compute (cmdRasterize). On exit every HZB level is
// written and visible.
void ClusterRenderer::Impl::cmdBuildHzb(VkCommandBuffer cmd, const sio::ClusterPush& p) {
  uint32_t slot = timer.cmdBegin(cmd, "hzb", kCS);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, hzbPipeline);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &descriptors.set, 0, nullptr);
  // Levels 1..5 per 16x16 tile of level 1, then one workgroup for the rest (cluster_hzb.comp).
  uint32_t w1 = (width + 1) / 2, h1 = (height + 1) / 2;
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
  timer.cmdEnd(cmd, slot, kCS);
}

// Pass-2 culling against the HZB of pass 1: late instances (then the phase-2 selection of the ones
// that pass) and the clusters left over from phase 1.
// barriers: the HZB, the late instances and the candidates visible; on exit pass 2's appends are.
void ClusterRenderer::Impl::cmdOcclusion(VkCommandBuffer cmd, const sio::ClusterPush& p, bool hierarchy) {
  uint32_t slot = timer.cmdBegin(cmd, "occlusion", kCS);
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
  timer.cmdEnd(cmd, slot, kCS);
}

// barriers: cmdRasterize's output visible to compute shaders. The color target ends in GENERAL with
// the resolve's writes available, which the readback expects.
void ClusterRenderer::Impl::cmdResolve(VkCommandBuffer cmd, const sio::ClusterPush& p) {
  uint32_t slot = timer.cmdBegin(cmd, "resolve");
  cmdImageBarrier(cmd, {color.handle(), VK_PIPELINE_STAGE_2_NONE, 0, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                        VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL});
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, resolvePipeline);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &descriptors.set, 0, nullptr);
  cmdPush(cmd, p, 0);
  vkCmdDispatch(cmd, (width + 7) / 8, (height + 7) / 8, 1); // 8x8 pixels per workgroup
  timer.cmdEnd(cmd, slot);
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
// drawn only when the hardware blend list is non-empty (ClusterCounters::blendDepthDraw); the
// compute blend raster reads the buffer itself, so an unwritten depth image is never read.
// barriers: on entry the opaque raster's writes visible (cmdPhaseBarrier, cmdRasterize's toRead).
void ClusterRenderer::Impl::cmdBlendDepth(VkCommandBuffer cmd, const sio::ClusterPush& p, bool bufferTarget) {
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
  uint32_t slot = timer.cmdBegin(cmd, "blend-z");
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
  vkCmdDrawIndirect(cmd, counters.handle(), offsetof(sio::ClusterCounters, blendDepthDraw), 1,
                    sizeof(VkDrawIndirectCommand));
  vkCmdEndRendering(cmd);
  cmdImageBarrier(cmd, {depth.handle(), kTests, VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT, kTests | kCS,
                        VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
                        VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL, VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL,
                        VK_IMAGE_ASPECT_DEPTH_BIT});
  timer.cmdEnd(cmd, slot);
}

// The hardware blend list (entries from the blend list's end) drawn with no colour output over the
// read-only opaque depth; its fragment shader appends to the transparency lists.
// barriers: the blend arguments visible; the depth prepared by cmdBlendDepth.
void ClusterRenderer::Impl::cmdHardwareBlend(VkCommandBuffer cmd, const sio::ClusterPush& p, bool mesh) {
  VkPipeline pipeline = blendHardwarePipeline(mesh);
  VkRenderingAttachmentInfo depthAtt{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
  depthAtt.imageView = depth.view();
  depthAtt.imageLayout = VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL;
  depthAtt.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
  depthAtt.storeOp = VK_ATTACHMENT_STORE_OP_NONE; // read-only: nothing to store
  VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
  ri.pDepthAttachment = &depthAtt;
  cmdBeginFullTarget(cmd, ri);
  cmdPush(cmd, p, MIRAGE_RASTER_BLEND_LIST + MIRAGE_LIST_DOWN);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout, 0, 1, &descriptors.set, 0, nullptr);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
  cmdDrawList(cmd, mesh, 2, MIRAGE_LIST_DOWN);
  vkCmdEndRendering(cmd);
}

// Alpha BLEND after the resolve (only for scenes with BLEND materials): the blend lists rasterized
// into per-pixel fragment lists, depth-tested against the opaque depth (the compute list by
// cluster_raster_blend.comp, the hardware list by cmdHardwareBlend), then the composite sorts and
// blends each pixel's fragments over the resolved colour. "blend" times both rasters; hybrid adds
// "blend-cs" and "blend-hw" for each alone, and the buffer backends' depth copy is "blend-z".
// barriers: the resolve's colour, the opaque depth and the blend arguments (cmdArgs pass 2) written;
// the heads zeroed at the frame start. On exit the colour is in GENERAL with its writes available.
void ClusterRenderer::Impl::cmdTransparency(VkCommandBuffer cmd, sio::ClusterPush p, BlendRaster blend, bool meshBlend,
                                            bool bufferTarget) {
  p.visibleAddress = blendVisible.address(); // ids of the blend passes name blend-list entries
  cmdPhaseBarrier(cmd, ctx.caps().meshShader);
  uint32_t slot = timer.cmdBegin(cmd, "blend");
  if (blend != BlendRaster::Compute) cmdBlendDepth(cmd, p, bufferTarget);
  if (blend != BlendRaster::Hardware) {
    uint32_t part = blend == BlendRaster::Hybrid ? timer.cmdBegin(cmd, "blend-cs", kCS) : 0;
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, blendRasterPipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &descriptors.set, 0, nullptr);
    cmdPush(cmd, p, MIRAGE_RASTER_BLEND_LIST);
    vkCmdDispatchIndirect(cmd, counters.handle(), dispatchArgsOffset(2, MIRAGE_LIST_UP));
    if (blend == BlendRaster::Hybrid) timer.cmdEnd(cmd, part, kCS);
  }
  if (blend != BlendRaster::Compute) {
    uint32_t part = blend == BlendRaster::Hybrid ? timer.cmdBegin(cmd, "blend-hw") : 0;
    cmdHardwareBlend(cmd, p, meshBlend);
    if (blend == BlendRaster::Hybrid) timer.cmdEnd(cmd, part);
  }
  timer.cmdEnd(cmd, slot);
  cmdPhaseBarrier(cmd, ctx.caps().meshShader);
  slot = timer.cmdBegin(cmd, "composite", kCS);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, compositePipeline);
  vkCmdDispatch(cmd, (width + 7) / 8, (height + 7) / 8, 1);
  timer.cmdEnd(cmd, slot, kCS);
}

ClusterRenderer::ClusterRenderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ClusterRenderer::~ClusterRenderer() = default;
const Bounds& ClusterRenderer::worldBounds() const { return impl_->scene.worldBounds; }
uint64_t ClusterRenderer::clusterCount() const { return impl_->scene.clusterCount; }

Status ClusterRenderer::setPvs(const lod::ClusterPvs* pvs) {
  Impl& d = *impl_;
  if (!pvs) {
    d.pvsInstances = {};
    d.pvsClusters = {};
    return Ok{};
  }
  if (pvs->instanceBitOffset.size() != d.scene.instanceCount)
    return Error{fmt::format("cluster PVS for {} instances, the scene has {}", pvs->instanceBitOffset.size(),
                             d.scene.instanceCount)};
  if (pvs->clusterBits.size() * 4 > d.ctx.caps().maxStorageBufferRange)
    return Error{fmt::format("cluster PVS of {} bytes exceeds the device's storage buffer range", pvs->bytes())};
  constexpr VkBufferUsageFlags kStorage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  d.pvsInstances = createBufferWithData<uint32_t>(d.ctx, pvs->instanceBitOffset, kStorage, "pvs instances");
  std::vector<uint32_t> bits = pvs->clusterBits;
  if (bits.empty()) bits.push_back(0); // every instance culled: the buffer still needs an address
  d.pvsClusters = createBufferWithData<uint32_t>(d.ctx, bits, kStorage, "pvs cluster bits");
  return Ok{};
}

Result<std::unique_ptr<ClusterRenderer>> ClusterRenderer::create(Context& context, const lod::LodAsset& asset) {
  auto data = uploadClusterScene(context, asset);
  if (!data) return data.error();
  auto impl = std::make_unique<Impl>(context, std::move(*data));
  impl->createDescriptors();
  impl->createPipelines();
  return std::unique_ptr<ClusterRenderer>(new ClusterRenderer(std::move(impl)));
}

namespace {

// The backend that runs: auto prefers hybrid (compute for small triangles, mesh shaders for large),
// then compute alone, then mesh shaders, then indirect draws.
Result<RasterBackend> resolveBackend(RasterBackend requested, const DeviceCapabilities& caps) {
  bool atomics = caps.int64BufferAtomics, fragmentAtomics = atomics && caps.fragmentStoresAndAtomics;
  if (requested == RasterBackend::Auto)
    return fragmentAtomics && caps.meshShader ? RasterBackend::Hybrid
           : atomics                          ? RasterBackend::Compute
           : caps.meshShader                  ? RasterBackend::Mesh
                                              : RasterBackend::Indirect;
  if (requested == RasterBackend::Mesh && !caps.meshShader)
    return Error{"--raster mesh: the device has no VK_EXT_mesh_shader"};
  if (requested == RasterBackend::Compute && !atomics)
    return Error{"--raster compute: the device has no 64-bit buffer atomics"};
  if (requested == RasterBackend::Hybrid && !fragmentAtomics)
    return Error{"--raster hybrid: the device has no 64-bit buffer atomics in fragment shaders"};
  return requested;
}

// The blend raster that runs: auto is hybrid whatever the opaque backend, measured on the H200
// (docs/render.md, "Blend rasters"): the city's large glass at street level takes 15.0 ms by
// compute, 0.28 hybrid, 0.25 hardware; 2500 AlphaBlendModeTest copies (5000 small clusters) 0.034
// by compute, 0.39 hardware, and hybrid sends them all to compute. Hardware needs fragment stores
// and atomics (the list append), else auto falls back to compute.
Result<BlendRaster> resolveBlendRaster(BlendRaster requested, const DeviceCapabilities& caps) {
  bool hardware = caps.fragmentStoresAndAtomics;
  if (requested == BlendRaster::Auto) return hardware ? BlendRaster::Hybrid : BlendRaster::Compute;
  if (requested != BlendRaster::Compute && !hardware)
    return Error{fmt::format("--blend-raster {}: the device has no stores and atomics in fragment shaders",
                             toString(requested))};
  return requested;
}

} // namespace

Result<ClusterRenderOutput> ClusterRenderer::render(const ClusterRenderSettings& cs) {
  const RenderSettings& s = cs.base;
  if (s.width == 0 || s.height == 0 || s.width > kMaxRenderDimension || s.height > kMaxRenderDimension)
    return Error{fmt::format("render size {}x{} is outside 1..{}", s.width, s.height, kMaxRenderDimension)};
  if (!(cs.tauPixels > 0.0f)) return Error{fmt::format("--tau {} must be a positive number of pixels", cs.tauPixels)};
  if (!(cs.hybridThreshold >= 0.0f))
    return Error{fmt::format("--hybrid-threshold {} must be a non-negative number of pixels", cs.hybridThreshold)};
  Impl& d = *impl_;
  auto resolved = resolveBackend(cs.raster, d.ctx.caps());
  if (!resolved) return resolved.error();
  RasterBackend backend = *resolved;
  auto blendResolved = resolveBlendRaster(cs.blendRaster, d.ctx.caps());
  if (!blendResolved) return blendResolved.error();
  BlendRaster blend = d.hasBlend() ? *blendResolved : BlendRaster::Compute;
  // The hardware blend raster: mesh shaders where the device has them, unless indirect was asked for.
  bool meshBlend = d.ctx.caps().meshShader && backend != RasterBackend::Indirect;
  bool bufferTarget = backend == RasterBackend::Compute || backend == RasterBackend::Hybrid;
  if (cs.surfels && !bufferTarget)
    return Error{fmt::format("mesh + surfel scenes share the 64-bit visibility buffer: --raster {} cannot draw "
                             "them (use compute or hybrid)",
                             toString(backend))};
  bool occlusion = cs.occlusionCulling && d.historyUsable;
  if (cs.readOwnedClusters && !occlusion)
    return Error{"reading the clusters that own pixels needs occlusion culling (its history)"};
  bool pvs = cs.pvsCulling && d.pvsInstances;
  bool dagTree = cs.selection == SelectionMode::Dag;
  bool hierarchy = dagTree || cs.selection == SelectionMode::Hierarchy ||
                   (cs.selection == SelectionMode::Auto && d.scene.instanceCount >= kHierarchyInstances);
  d.traversalDepth = dagTree ? d.scene.dagDepth : d.scene.lodDepth;
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
            (cs.frustumCulling ? MIRAGE_FRAME_FRUSTUM_CULL : 0u) | (bufferTarget ? MIRAGE_FRAME_SOURCE_BUFFER : 0u) |
            (backend == RasterBackend::Hybrid ? MIRAGE_FRAME_HYBRID : 0u) | (occlusion ? MIRAGE_FRAME_OCCLUSION : 0u) |
            (cs.coneCulling ? MIRAGE_FRAME_CONE_CULL : 0u) | (hierarchy ? MIRAGE_FRAME_HIERARCHY : 0u) |
            (pvs ? MIRAGE_FRAME_PVS : 0u) | (blend == BlendRaster::Hybrid ? MIRAGE_FRAME_BLEND_HYBRID : 0u) |
            (blend == BlendRaster::Hardware ? MIRAGE_FRAME_BLEND_HARDWARE : 0u) | (dagTree ? MIRAGE_FRAME_DAG : 0u);
  if (pvs) {
    f.pvsInstanceAddress = d.pvsInstances.address();
    f.pvsClusterAddress = d.pvsClusters.address();
  }
  f.visibleCapacity = d.visibleCapacity;
  f.instanceCount = d.scene.instanceCount;
  f.background = s.background;
  f.hybridThreshold = cs.hybridThreshold;
  f.hzbLevels = d.hzbLevels;
  f.coneAddress = d.scene.cones.address();
  f.historyAddress = d.history.address();
  f.candidateAddress = d.candidates.address();
  f.hzbAddress = d.hzb.address();
  f.lateInstanceAddress = d.lateInstances.address();
  f.instanceHistoryBase = uint32_t(d.scene.instancedClusters);
  std::copy(std::begin(d.hzbOffset), std::end(d.hzbOffset), std::begin(f.hzbOffset));
  if (cs.surfels) {
    if (!d.fade) {
      d.fade = createBuffer(d.ctx, uint64_t(std::max(d.scene.instanceCount, 1u)) * 4,
                            VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::GpuOnly,
                            "mesh fade");
      d.surfelLink = createBuffer(d.ctx, sizeof(sio::ClusterSurfelLink), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                  MemoryUsage::Upload, "surfel link");
    }
    SurfelStageFrame sf;
    sf.viewProj = f.viewProj;
    sf.eye = cam.eye;
    sf.znear = cam.znear;
    sf.pixelScale = f.errorScale; // the same pixels per world unit at distance 1
    sf.width = s.width;
    sf.height = s.height;
    sf.visBufferAddress = d.visBuffer.address();
    sf.meshFadeAddress = d.fade.address();
    SurfelRenderSettings ss = cs.surfelSettings;
    ss.meshFade = true;
    ss.frustumCulling = cs.frustumCulling;
    if (Status st = cs.surfels->stagePrepare(ss, sf); !st) return st.error();
    sio::ClusterSurfelLink link = cs.surfels->stageLink();
    std::memcpy(d.surfelLink.mapped(), &link, sizeof(link));
    f.fadeAddress = d.fade.address();
    f.surfelLinkAddress = d.surfelLink.address();
  }
  f.nodeAddress = d.scene.lodNodes.address();
  f.leafClusterAddress = d.scene.leafClusters.address();
  f.traversalAddress = d.traversal.address();
  f.queueAddress[0] = d.queues[0].address();
  f.queueAddress[1] = d.queues[1].address();
  f.queueCapacity = d.queueCapacity;
  if (d.hasBlend()) {
    f.blendVisibleAddress = d.blendVisible.address();
    f.oitHeadAddress = d.oitHeads.address();
    f.oitNodeAddress = d.oitNodes.address();
    f.blendCapacity = d.blendCapacity;
    f.oitNodeCapacity = d.oitNodeCapacity;
  }
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
    if (hierarchy) vkCmdFillBuffer(cmd, d.traversal.handle(), 0, VK_WHOLE_SIZE, 0);
    if (bufferTarget) vkCmdFillBuffer(cmd, d.visBuffer.handle(), 0, VK_WHOLE_SIZE, 0);
    if (d.hasBlend()) vkCmdFillBuffer(cmd, d.oitHeads.handle(), 0, VK_WHOLE_SIZE, 0); // empty lists
    if (cs.surfels) { // instances without a cloud keep fade 0: meshes only
      vkCmdFillBuffer(cmd, d.fade.handle(), 0, VK_WHOLE_SIZE, 0);
      cs.surfels->stageCmdClear(cmd);
    }
    cmdPhaseBarrier(cmd, d.ctx.caps().meshShader);
    if (cs.surfels) { // k and the fade per instance first: the mesh passes read the fade
      cs.surfels->stageCmdPrefix(cmd, d.timer);
      cmdPhaseBarrier(cmd, d.ctx.caps().meshShader);
    }
    d.cmdSelect(cmd, p, hierarchy); // instance cull; LOCALCUT + frustum + cones: pass-1 lists, candidates
    if (occlusion) {                // the select pass read last frame's history; the resolve writes this frame's
      vkCmdFillBuffer(cmd, d.history.handle(), 0, VK_WHOLE_SIZE, 0);
      cmdPhaseBarrier(cmd, d.ctx.caps().meshShader);
    }
    d.cmdArgs(cmd, p, /*pass=*/0);      // pass-1 raster arguments (everything without occlusion)
    d.cmdRasterize(cmd, p, backend, 0); // visibility: (cluster, triangle) per pixel
    if (occlusion) {
      d.cmdBuildHzb(cmd, p);             // farthest-depth pyramid of pass 1
      d.cmdOcclusion(cmd, p, hierarchy); // pass-2 cull: candidates against the HZB
      d.cmdArgs(cmd, p, /*pass=*/1);
      d.cmdRasterize(cmd, p, backend, 1); // the newly visible clusters
    }
    if (cs.surfels) { // after the meshes, so the HZB holds meshes only (as without surfels)
      cs.surfels->stageCmdSplat(cmd, d.timer);
      cmdPhaseBarrier(cmd, d.ctx.caps().meshShader);
    }
    if (d.hasBlend()) d.cmdArgs(cmd, p, /*pass=*/2); // the blend list is complete after both phases
    d.cmdResolve(cmd, p); // fetch, interpolate, shade; with occlusion: the clusters owning pixels
    if (d.hasBlend())     // blend raster into fragment lists, sorted composite
      d.cmdTransparency(cmd, p, blend, meshBlend, bufferTarget);
    d.timer.cmdEnd(cmd, frameSlot);
  });

  ClusterRenderOutput out;
  out.image.stats.passTimes = d.timer.read();
  sio::ClusterCounters c{};
  std::vector<uint8_t> raw = readbackBuffer(d.ctx, d.counters, sizeof(c));
  std::memcpy(&c, raw.data(), sizeof(c));
  ClusterStats& st = out.stats;
  if (hierarchy) {
    sio::ClusterTraversal t{};
    std::vector<uint8_t> rawT = readbackBuffer(d.ctx, d.traversal, sizeof(t));
    std::memcpy(&t, rawT.data(), sizeof(t));
    st.nodesTested = t.nodesTested;
    st.selectionPasses = d.traversalDepth + 1;
  }
  st.selection = dagTree ? SelectionMode::Dag : hierarchy ? SelectionMode::Hierarchy : SelectionMode::Flat;
  st.instancesVisible = c.visibleInstances;
  st.clustersTested = c.clustersTested;
  st.selectRows = c.selectArgs[1];
  st.clustersSelected = c.clustersSelected;
  st.clustersFrustumCulled = c.clustersFrustumCulled;
  st.clustersBackfaceCulled = c.clustersBackfaceCulled;
  st.clustersPass1 = c.clustersPass1;
  st.clustersOcclusionTested = std::min(c.candidates, d.visibleCapacity);
  st.clustersOcclusionCulled = c.clustersOcclusionCulled;
  st.instancesLate = c.lateInstances;
  st.instancesOcclusionCulled = c.instancesOcclusionCulled;
  st.historyKept = c.historyKept;
  st.clustersDrawn = c.listEnd[0] + c.listEnd[1] + std::min(c.blendClusters, d.blendCapacity);
  st.clustersBlend = std::min(c.blendClusters, d.blendCapacity);
  st.clustersBlendHardware = c.blendListEnd[MIRAGE_LIST_DOWN];
  st.blendRaster = blend;
  st.oitFragments = c.oitNodes;
  st.oitPoolOverflow = c.oitNodes > d.oitNodeCapacity ? c.oitNodes - d.oitNodeCapacity : 0;
  st.oitLayersDropped = c.oitLayersDropped;
  st.clustersHardware = c.clustersHardware;
  st.trianglesNearClipped = c.trianglesNearClipped;
  st.clustersOverflow = c.clustersOverflow;
  st.trianglesRasterized = c.trianglesSelected;
  st.instancesPvsCulled = c.instancesPvsCulled;
  st.clustersPvsCulled = c.clustersPvsCulled;
  st.pvs = pvs;
  st.raster = backend;
  st.occlusion = occlusion;
  if (cs.surfels) st.surfels = cs.surfels->stageStats();
  out.image.stats.drawCalls = 1;
  out.image.stats.trianglesSubmitted = c.trianglesSelected;

  if (cs.readOwnedClusters) {
    // The resolve set bit (historyOffset + cluster) of every cluster owning a pixel this frame.
    std::vector<uint8_t> bits = readbackBuffer(d.ctx, d.history, (d.scene.instancedClusters + 31) / 32 * 4);
    const uint32_t* words = reinterpret_cast<const uint32_t*>(bits.data());
    uint64_t base = 0;
    for (uint32_t i = 0; i < d.scene.instanceCount; base += d.scene.instanceClusters[i++])
      for (uint32_t k = 0; k < d.scene.instanceClusters[i]; ++k)
        if ((words[(base + k) / 32] >> ((base + k) % 32)) & 1u) out.ownedClusters.emplace_back(i, k);
  }
  if (!s.readImage) return out;
  std::vector<uint8_t> img = readbackImage(d.ctx, d.color, VK_IMAGE_LAYOUT_GENERAL, 8);
  convertHalfImage(img, s.width, s.height, s.readLinear, out.image);
  return out;
}

} // namespace mirage::render
