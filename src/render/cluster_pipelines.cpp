// ClusterRenderer set-up: descriptors, pipelines, per-scene buffers and per-size targets.
#include <algorithm>
#include <cassert>

#include "cluster_impl.h"
#include "render_util.h"
#include "mirage/gpu/commands.h"
#include "mirage/gpu/shaders.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

// See cluster_impl.h.
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
  std::vector<VkDescriptorImageInfo> infos;
  for (const Image& img : scene.textures)
    infos.push_back({scene.sampler, img.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL});
  for (DescriptorSet& set : descriptors) {
    set = createDescriptorSet(ctx, bindings);
    writeImageDescriptors(ctx, set.set, 0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, infos);
  }
}

void ClusterRenderer::Impl::createPipelines() {
  const DeviceCapabilities& caps = ctx.caps();
  pushStages = VK_SHADER_STAGE_COMPUTE_BIT | VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;
  if (caps.meshShader) pushStages |= VK_SHADER_STAGE_MESH_BIT_EXT;
  layout = createPipelineLayout(ctx, {descriptors[0].layout.get()}, sizeof(sio::ClusterPush), pushStages);
  cullPipeline = createComputePipeline(ctx, "cluster_cull.comp", layout);
  selectPipeline = createComputePipeline(ctx, "cluster_select.comp", layout);
  traversePipeline = createComputePipeline(ctx, "cluster_traverse.comp", layout);
  argsPipeline = createComputePipeline(ctx, "cluster_args.comp", layout);
  occlusionPipeline = createComputePipeline(ctx, "cluster_occlusion.comp", layout);
  instanceOcclusionPipeline = createComputePipeline(ctx, "cluster_instance_occlusion.comp", layout);
  hzbPipeline = createComputePipeline(ctx, "cluster_hzb.comp", layout);
  resolvePipeline = createComputePipeline(ctx, "cluster_resolve.comp", layout, scene.resolveSpecialization);
  // Compute rasterizers (cluster_raster.glsl), specialized by eyes and workgroup size
  // (kClusterRasterLanes per eye; stereo draws both eyes with twice the threads).
  const uint32_t kMono[] = {1, kClusterRasterLanes}, kStereo[] = {2, 2 * kClusterRasterLanes};
  bool computeRaster = caps.int64BufferAtomics && caps.int64SharedAtomics; // cluster_frame.cpp's condition
  if (computeRaster) {
    rasterPipeline = createComputePipeline(ctx, "cluster_raster.comp", layout, kMono);
    rasterStereoPipeline = createComputePipeline(ctx, "cluster_raster.comp", layout, kStereo);
    rasterLeanPipeline = createComputePipeline(ctx, "cluster_raster_lean.comp", layout, kMono);
    rasterLeanStereoPipeline = createComputePipeline(ctx, "cluster_raster_lean.comp", layout, kStereo);
  }
  if (computeRaster && scene.hasMask) {
    rasterMaskPipeline = createComputePipeline(ctx, "cluster_raster_mask.comp", layout, kMono);
    rasterMaskStereoPipeline = createComputePipeline(ctx, "cluster_raster_mask.comp", layout, kStereo);
  }
  if (scene.blendInstancedClusters > 0) {
    blendRasterPipeline = createComputePipeline(ctx, "cluster_raster_blend.comp", layout, kMono);
    blendRasterStereoPipeline = createComputePipeline(ctx, "cluster_raster_blend.comp", layout, kStereo);
    createCompositePipeline();
    // The blend queue takes a triangle's slot and first tile with a 64-bit compare-and-swap; packed
    // transparency keeps a pixel's nearest by 64-bit maxima.
    if (caps.int64BufferAtomics) {
      blendQueuePipeline = createComputePipeline(ctx, "cluster_blend_queue.comp", layout);
      oitRangesLayout = createPipelineLayout(ctx, {}, sizeof(sio::OitRangesPush), VK_SHADER_STAGE_COMPUTE_BIT);
      oitRangesPipeline = createComputePipeline(ctx, "oit_ranges.comp", oitRangesLayout);
    }
  }
  indirectPipeline = createVisPipeline(/*mesh=*/false, /*atomic=*/false);
  if (caps.meshShader) meshPipeline = createVisPipeline(/*mesh=*/true, /*atomic=*/false);
  if (caps.int64BufferAtomics && caps.fragmentStoresAndAtomics) {
    indirectAtomicPipeline = createVisPipeline(/*mesh=*/false, /*atomic=*/true);
    if (caps.meshShader) meshAtomicPipeline = createVisPipeline(/*mesh=*/true, /*atomic=*/true);
  }

  constexpr VkBufferUsageFlags kStorage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  visibleCapacity = uint32_t(std::clamp<uint64_t>(scene.instancedClusters, 1, kMaxVisibleClusters));
  for (uint32_t i = 0; i < kMaxFramesInFlight; ++i) {
    frames[i] = createBuffer(ctx, kFrameStride * kFramesPerSlot, kStorage, MemoryUsage::Upload, "cluster frame");
    readbacks[i] = createBuffer(ctx, sizeof(sio::ClusterCounters) + sizeof(sio::ClusterTraversal),
                                VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::Readback, "cluster counters readback");
  }
  visibleInstances = createBuffer(ctx, scene.instanceCount * uint64_t(sizeof(sio::VisibleInstance)), kStorage,
                                  MemoryUsage::GpuOnly, "visible instances");
  lateInstances = createBuffer(ctx, scene.instanceCount * uint64_t(sizeof(sio::VisibleInstance)), kStorage,
                               MemoryUsage::GpuOnly, "late instances");
  // Zeroed once: entry 0 is then always a valid (instance, cluster) pair, which the resolve reads
  // for background pixels too (see cluster_resolve.comp). With residency a record slot is valid
  // only while its page is drawn: each frame sets entry 0 again (cmdResidencyUpload, DST).
  std::vector<sio::VisibleCluster> zeros(visibleCapacity, sio::VisibleCluster{0, 0});
  visible = createBufferWithData<sio::VisibleCluster>(
      ctx, zeros, kStorage | VK_BUFFER_USAGE_TRANSFER_SRC_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
      "visible clusters");                // SRC: readVisibility
  if (scene.blendInstancedClusters > 0) { // zeroed: entry 0 is valid for every lane (as `visible`)
    blendCapacity = uint32_t(std::min<uint64_t>(scene.blendInstancedClusters, kMaxVisibleClusters));
    std::vector<sio::VisibleCluster> blendZeros(blendCapacity, sio::VisibleCluster{0, 0});
    blendVisible = createBufferWithData<sio::VisibleCluster>(
        ctx, blendZeros, kStorage | VK_BUFFER_USAGE_TRANSFER_DST_BIT, "blend clusters");
    if (blendQueuePipeline) {
      blendQueueCapacity = uint32_t(std::clamp<uint64_t>(uint64_t(blendCapacity) * MIRAGE_CLUSTER_MAX_TRIANGLES * 4, 64,
                                                         kMaxBlendQueueTriangles));
      blendQueue = createBuffer(ctx, blendQueueCapacity * uint64_t(sizeof(sio::BlendQueueTriangle)), kStorage,
                                MemoryUsage::GpuOnly, "blend queue");
    }
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

// Image backends: (visible entry + 1, triangle) into an R32G32 target, depth-tested. Hybrid's
// hardware list: no attachments, the fragment shader does the compute rasterizer's atomicMax.
// `overdraw` (image backends): the *_overdraw.frag variant counting samples for the debug view.
// `multiview`: both stereo eyes in one draw (view mask 0b11; the fragment shaders serve both kinds).
gpu::Unique<VkPipeline> ClusterRenderer::Impl::createVisPipeline(bool mesh, bool atomic, bool overdraw,
                                                                 bool multiview) {
  GraphicsPipelineDesc d;
  (mesh ? d.meshShader : d.vertexShader) = mesh ? (multiview ? "cluster_vis_multiview.mesh" : "cluster_vis.mesh")
                                                : (multiview ? "cluster_vis_multiview.vert" : "cluster_vis.vert");
  d.viewMask = multiview ? 0b11u : 0u;
  // Scenes with MASK materials take the *_mask variants (alpha test); others run no alpha code.
  std::string fragment = std::string(mesh ? (atomic ? "cluster_vis_mesh_atomic" : "cluster_vis_mesh")
                                          : (atomic ? "cluster_vis_atomic" : "cluster_vis")) +
                         (scene.hasMask ? "_mask" : "") + (overdraw ? "_overdraw.frag" : ".frag");
  d.fragmentShader = fragment;
  d.layout = layout;
  if (!atomic) {
    d.colorFormats = {kVisFormat};
    d.depthFormat = kDepthFormat;
  }
  return createGraphicsPipeline(ctx, d);
}

uint32_t ClusterRenderer::Impl::inFlightSlots() const {
  uint32_t slots = 0;
  for (uint32_t i = 0; i < kMaxFramesInFlight; ++i)
    if (recorded[i]) slots |= 1u << i;
  return slots;
}

// New targets for a new size: the replaced ones live until every slot recorded and not yet
// collected completed (no device wait; each slot's descriptor set names its own frame's targets).
void ClusterRenderer::Impl::ensureTargets(uint32_t w, uint32_t h, uint32_t colorW) {
  if (w == width && h == height && colorW == colorWidth) return;
  const uint32_t inFlight = inFlightSlots();
  for (Image* image : {&color, &vis, &depth, &layeredVis, &layeredDepth}) retired.retire(std::move(*image), inFlight);
  for (Buffer* buffer : {&visBuffer, &hzb, &overdrawCounts, &oitHeads, &splatAccum})
    retired.retire(std::move(*buffer), inFlight);
  color = createImage2D(ctx, colorW, h, kColorFormat, VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                        "color");
  // Visibility targets as wide as the colour target: stereo rasterizes both eyes side by side.
  // TRANSFER_DST: stereo by multiview copies its layers in.
  vis = createImage2D(
      ctx, colorW, h, kVisFormat,
      VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, "visibility");
  depth = createImage2D(ctx, colorW, h, kDepthFormat,
                        VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT |
                            VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                        "visibility depth");
  visImagesDefined = false;
  visBufferZero = false;
  layeredVis = {}; // made at the new size on first use
  layeredDepth = {};
  visBuffer = createBuffer(ctx, uint64_t(colorW) * h * 8,
                           VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                               VK_BUFFER_USAGE_TRANSFER_SRC_BIT, // SRC: readVisibility
                           MemoryUsage::GpuOnly, "visibility64");
  // HZB levels 1.. down to 1x1 (at least level 1) in one float buffer; level 0 would be the depth
  // itself, which the level-1 build reads directly.
  uint64_t floats = 0;
  hzbLevels = 1;
  for (uint32_t lw = (colorW + 1) / 2, lh = (h + 1) / 2; hzbLevels < MIRAGE_HZB_MAX_LEVELS; // stereo: both eyes
       lw = (lw + 1) / 2, lh = (lh + 1) / 2) {
    hzbOffset[hzbLevels++] = uint32_t(floats);
    floats += uint64_t(lw) * lh;
    if (lw == 1 && lh == 1) break;
  }
  hzb = createBuffer(ctx, floats * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::GpuOnly, "hzb");
  overdrawCounts = {}; // the overdraw view's counts, made at the new size on first use
  width = w;
  height = h;
  colorWidth = colorW;
  if (hasBlend() || particleOit) createOitHeads();
  oitNodesPerPixel = 0; // the pool follows the size (ensureOitPool)
}

// The transparency lists' heads at the target size (both eyes in stereo; the caller retired the old).
void ClusterRenderer::Impl::createOitHeads() {
  uint64_t pixels = uint64_t(colorWidth) * height;
  oitHeads = createBuffer(ctx, pixels * sizeof(sio::OitPixelHead),
                          VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::GpuOnly,
                          "transparency heads");
  if (!oitRangesPipeline) return;
  uint64_t blocks = (pixels + MIRAGE_OIT_RANGE_BLOCK - 1) / MIRAGE_OIT_RANGE_BLOCK;
  retired.retire(std::move(oitRangesScratch), inFlightSlots());
  oitRangesScratch =
      createBuffer(ctx, sizeof(sio::OitRangesScratch) + blocks * (MIRAGE_OIT_MAX_LAYERS + 1 + 2) * sizeof(uint32_t),
                   VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::GpuOnly, "transparency ranges scratch");
}

// The transparency node pool for the current size: nodesPerPixel per pixel (both eyes in stereo;
// 0: kOitNodesPerPixel, or kOitNodesPerPixelParticles once particles use the lists), capped by what
// one storage buffer may address, and with particles the colour beside each node. A replaced pool
// waits for the frames in flight.
void ClusterRenderer::Impl::ensureOitPool(uint32_t nodesPerPixel) {
  if (!hasBlend() && !particleOit) return;
  if (nodesPerPixel == 0) nodesPerPixel = particleOit ? kOitNodesPerPixelParticles : kOitNodesPerPixel;
  if (oitNodes && oitNodesPerPixel == nodesPerPixel) return;
  retired.retire(std::move(oitNodes), inFlightSlots());
  retired.retire(std::move(oitColors), inFlightSlots());
  oitPackedFrames = 0; // another pool: fixed slots may fit again
  uint64_t pixels = uint64_t(colorWidth) * height;
  oitNodeCapacity = uint32_t(std::min<uint64_t>(
      {pixels * nodesPerPixel, ctx.caps().maxStorageBufferRange / sizeof(sio::OitNode), uint64_t(UINT32_MAX) - 1}));
  oitNodes = createBuffer(ctx, uint64_t(oitNodeCapacity) * sizeof(sio::OitNode),
                          VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::GpuOnly,
                          "transparency nodes");
  assert(oitNodes.address() % 16 == 0); // the composite reads packed keys in 16-byte pairs (oitSortedRange)
  // Colours beside the nodes: particles'.
  if (particleOit)
    oitColors = createBuffer(ctx, uint64_t(oitNodeCapacity) * 8, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                             MemoryUsage::GpuOnly, "transparency colours");
  oitNodesUnzeroed = true; // cmdFrame zeroes it (the lists' overflow rule tells unwritten nodes by 0)
  oitNodesPerPixel = nodesPerPixel;
}

// The slot's previous frame completed (the caller's contract), so its set may be rewritten.
void ClusterRenderer::Impl::writeTargetDescriptors(uint32_t slot) {
  VkDescriptorImageInfo visInfo{scene.nearestSampler, vis.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  VkDescriptorImageInfo colorInfo{VK_NULL_HANDLE, color.view(), VK_IMAGE_LAYOUT_GENERAL};
  VkDescriptorImageInfo depthInfo{scene.nearestSampler, depth.view(), VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL};
  VkDescriptorSet set = descriptors[slot].set;
  writeImageDescriptors(ctx, set, 1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, {&visInfo, 1});
  writeImageDescriptors(ctx, set, 2, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, {&colorInfo, 1});
  writeImageDescriptors(ctx, set, 3, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, {&depthInfo, 1});
}

// Stereo by multiview: this frame's visibility pipeline and, for the image backends, the 2-layer
// targets (one eye per layer, width x height).
void ClusterRenderer::Impl::ensureMultiview(const ClusterFramePlan& plan) {
  bool atomic = plan.backend == RasterBackend::Hybrid;
  bool mesh = atomic ? hybridListMesh() : plan.backend == RasterBackend::Mesh; // as cmdRasterize picks
  if (!multiviewPipelines[mesh][atomic])
    multiviewPipelines[mesh][atomic] = createVisPipeline(mesh, atomic, /*overdraw=*/false, /*multiview=*/true);
  if (plan.bufferTarget || layeredVis.handle()) return;
  VkImageCreateInfo ci{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
  ci.imageType = VK_IMAGE_TYPE_2D;
  ci.extent = {width, height, 1};
  ci.mipLevels = 1;
  ci.arrayLayers = 2;
  ci.samples = VK_SAMPLE_COUNT_1_BIT;
  ci.tiling = VK_IMAGE_TILING_OPTIMAL;
  ci.format = kVisFormat;
  ci.usage = VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  layeredVis = createImage(ctx, ci, VK_IMAGE_ASPECT_COLOR_BIT, "visibility layers");
  ci.format = kDepthFormat;
  ci.usage = VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
  layeredDepth = createImage(ctx, ci, VK_IMAGE_ASPECT_DEPTH_BIT, "visibility depth layers");
}

sio::ClusterPush ClusterRenderer::Impl::push() const {
  sio::ClusterPush p{};
  p.frameAddress = frames[currentSlot].address();
  // With residency one page pool holds the vertices, vertex ids, index words and cluster records
  // alike (cluster_residency.cpp): the four addresses name it.
  p.vertexAddress = scene.vertices.address();
  p.clusterAddress = scene.clusters ? scene.clusters.address() : p.vertexAddress;
  p.clusterVertexAddress = scene.clusterVertices ? scene.clusterVertices.address() : p.vertexAddress;
  p.indexAddress = scene.indices ? scene.indices.address() : p.vertexAddress;
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

} // namespace mirage::render
