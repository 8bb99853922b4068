// SurfelRenderer: upload, pipelines and the per-frame command sequence (docs/surfels.md, "Rendering").
#include "mirage/render/surfel_renderer.h"

#include <algorithm>
#include <cstring>
#include <numeric>
#include <unordered_map>

#include <fmt/format.h>

#include "render_util.h"
#include "mirage/gpu/commands.h"
#include "mirage/gpu/descriptors.h"
#include "mirage/gpu/pipeline.h"
#include "mirage/gpu/query.h"
#include "mirage/shaderio/surfel_render.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

namespace {

constexpr VkFormat kColorFormat = VK_FORMAT_R16G16B16A16_SFLOAT; // as the mesh renderers
constexpr VkFormat kVisFormat = VK_FORMAT_R32G32_UINT;           // (id, 0), as the cluster renderer
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
constexpr VkBufferUsageFlags kStorage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
constexpr VkAccessFlags2 kShaderRW = VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT;
constexpr VkPipelineStageFlags2 kCS = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT;
constexpr VkShaderStageFlags kPushStages =
    VK_SHADER_STAGE_COMPUTE_BIT | VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;

// Morton code of a quantized position: the three 21-bit coordinates interleaved (x lowest).
uint64_t spreadBits21(uint32_t v) {
  uint64_t x = v & 0x1fffffu;
  x = (x | x << 32) & 0x1f00000000ffffull;
  x = (x | x << 16) & 0x1f0000ff0000ffull;
  x = (x | x << 8) & 0x100f00f00f00f00full;
  x = (x | x << 4) & 0x10c30c30c30c30c3ull;
  x = (x | x << 2) & 0x1249249249249249ull;
  return x;
}

uint64_t mortonCode(const sio::Surfel& s) {
  constexpr uint32_t kMask = (1u << MIRAGE_SURFEL_POSITION_BITS) - 1u;
  uint32_t x = s.posLo & kMask, y = (s.posLo >> 21) | ((s.posHi & 0x3ffu) << 11), z = s.posHi >> 10;
  return spreadBits21(x) | spreadBits21(y) << 1 | spreadBits21(z) << 2;
}

} // namespace

std::vector<uint32_t> coherentSurfelOrder(const surfels::SurfelCloud& cloud, uint32_t minBlock) {
  uint32_t n = uint32_t(cloud.size());
  std::vector<uint32_t> at(n);
  std::iota(at.begin(), at.end(), 0u);
  std::vector<uint64_t> codes(n);
  for (uint32_t i = 0; i < n; ++i) codes[i] = mortonCode(cloud.surfels[i]);
  for (uint32_t start = 0; start < n;) {
    uint32_t end = coherentBlockEnd(start, n, minBlock);
    std::sort(at.begin() + start, at.begin() + end,
              [&](uint32_t a, uint32_t b) { return codes[a] != codes[b] ? codes[a] < codes[b] : a < b; });
    start = end;
  }
  return at;
}

static_assert(std::has_single_bit(coherentMinBlock(SurfelOrder::Coherent)) &&
                  std::has_single_bit(coherentMinBlock(SurfelOrder::Coherent256)) &&
                  coherentMinBlock(SurfelOrder::Coherent256) >= 32,
              "coherent blocks tile the order, and hold whole warps, only with power-of-two sizes >= 32");

const char* toString(SurfelOrder o) { return nameOf(kSurfelOrderNames, o); }
Result<SurfelOrder> parseSurfelOrder(std::string_view text) {
  return parseNamed(text, "surfel order", kSurfelOrderNames);
}
const char* toString(SurfelRaster r) { return nameOf(kSurfelRasterNames, r); }
Result<SurfelRaster> parseSurfelRaster(std::string_view text) {
  return parseNamed(text, "--surfel-raster", kSurfelRasterNames);
}
const char* toString(SurfelMerge m) { return nameOf(kSurfelMergeNames, m); }
Result<SurfelMerge> parseSurfelMerge(std::string_view text) { return parseNamed(text, "--merge", kSurfelMergeNames); }

// SurfelRenderFrame::flags for the merge choice.
static uint32_t mergeFlags(SurfelMerge m) {
  return m == SurfelMerge::On ? MIRAGE_SURFEL_MERGE_ALL : m == SurfelMerge::Auto ? MIRAGE_SURFEL_MERGE_AUTO : 0u;
}

struct SurfelRenderer::Impl {
  Context& ctx;
  Buffer positions, attributes, radii, clouds, instances, materials; // set-up time
  Buffer frame, states, counters, draws, visBuffer, batchInstance;   // per frame
  std::vector<Image> textures;                                       // one white texel: shading.glsl's array
  Unique<VkSampler> sampler, nearestSampler;
  DescriptorSet descriptors;
  Unique<VkPipelineLayout> layout;
  Unique<VkPipeline> prefixPipeline, scanPipeline, rasterPipeline, resolvePipeline;
  Unique<VkPipeline> splatPipelines[2][2]; // [merge pipeline (per-instance choice)][back-face culling]
  bool cullBackFaces = false;              // the frame's settings: which splat pipeline runs
  bool subgroupMerge = false;
  Image color, vis, depth;
  uint32_t width = 0, height = 0, instanceCount = 0;
  uint64_t surfelCount = 0, instancedCount = 0;
  uint64_t maxBatches = 0; // splat batches when every instance draws all its surfels
  Bounds worldBounds;
  SurfelOrder order = kDefaultSurfelOrder;
  GpuTimer timer;

  explicit Impl(Context& c) : ctx(c), timer(c) {}
  Status upload(const SurfelScene& scene);
  void createPipelines();
  void ensureTargets(uint32_t w, uint32_t h);
  sio::SurfelRenderPush push() const;
  void cmdPrefix(VkCommandBuffer cmd, const sio::SurfelRenderPush& p, GpuTimer& t);
  void cmdSplat(VkCommandBuffer cmd, SurfelRaster raster, GpuTimer& t); // push constants from cmdPrefix
  sio::SurfelRenderPush stagePush{}; // mixed scenes: the shared visibility buffer and fade array
  void cmdResolve(VkCommandBuffer cmd, const sio::SurfelRenderPush& p);
};

Status SurfelRenderer::Impl::upload(const SurfelScene& scene) {
  if (scene.clouds.empty() || scene.instances.empty()) return Error{"surfel scene has no clouds or no instances"};
  std::vector<glm::uvec2> pos, attr;
  std::vector<float> prefixRadii;
  std::vector<sio::SurfelRenderCloud> gpuClouds;
  std::vector<sio::GpuMaterial> gpuMaterials;
  // Coherent order: one sort per distinct cloud (the benchmark places one cloud many times).
  std::unordered_map<const surfels::SurfelCloud*, std::vector<uint32_t>> orders;
  for (const SurfelScene::Cloud& c : scene.clouds) {
    const surfels::SurfelCloud& cloud = *c.cloud;
    sio::SurfelRenderCloud g{};
    float P = float(cloud.referenceCount) * cloud.referenceMeanSpacing * cloud.referenceMeanSpacing;
    g.boxMin = glm::vec4(cloud.box.min, P);
    constexpr float kSteps = float((1u << MIRAGE_SURFEL_POSITION_BITS) - 1u);
    g.boxStep = glm::vec4((cloud.box.max - cloud.box.min) / kSteps, 0.0f);
    g.firstSurfel = uint32_t(pos.size());
    g.count = uint32_t(cloud.size());
    g.material = uint32_t(gpuMaterials.size());
    g.coherentMinBlock = coherentMinBlock(order);
    gpuClouds.push_back(g);
    Material m = c.material;
    m.baseColorTexture = m.metallicRoughnessTexture = m.normalTexture = m.occlusionTexture = m.emissiveTexture = -1;
    gpuMaterials.push_back(toGpuMaterial(m, 0));
    if (pos.size() + cloud.size() > 0xfffffffeull) return Error{"surfel scene holds more than 2^32 - 2 surfels"};
    // Radii belong to prefix lengths, not to surfels: they keep the blue-noise order.
    for (size_t i = 0; i < cloud.size(); ++i) prefixRadii.push_back(i < cloud.radii.size() ? cloud.radii[i] : 0.0f);
    const std::vector<uint32_t>* at = nullptr;
    if (g.coherentMinBlock != 0) {
      auto [it, added] = orders.try_emplace(&cloud);
      if (added) it->second = coherentSurfelOrder(cloud, g.coherentMinBlock);
      at = &it->second;
    }
    // Positions and attributes move together, so a visibility id still names its own attributes.
    for (size_t i = 0; i < cloud.size(); ++i) {
      const shaderio::Surfel& s = cloud.surfels[at ? (*at)[i] : i];
      pos.push_back({s.posLo, s.posHi});
      attr.push_back({s.normal, s.color});
    }
  }
  std::vector<sio::SurfelRenderInstance> gpuInstances;
  for (const SurfelScene::Placement& p : scene.instances) {
    if (p.cloud >= scene.clouds.size())
      return Error{fmt::format("surfel instance names cloud {} of {}", p.cloud, scene.clouds.size())};
    const surfels::SurfelCloud& cloud = *scene.clouds[p.cloud].cloud;
    sio::SurfelRenderInstance g{};
    g.model = p.transform;
    g.normalMatrix = glm::transpose(glm::inverse(p.transform));
    g.maxScale = maxAxisScale(p.transform);
    Bounds world = transformBounds(cloud.box, p.transform);
    g.sphere = glm::vec4(world.center(), 0.5f * glm::length(world.extent()));
    g.cloud = p.cloud;
    g.meshInstance = p.meshInstance;
    gpuInstances.push_back(g);
    worldBounds.add(world.min);
    worldBounds.add(world.max);
    instancedCount += cloud.size();
    maxBatches += (cloud.size() + MIRAGE_SURFEL_BATCH - 1) / MIRAGE_SURFEL_BATCH;
  }
  surfelCount = pos.size();
  instanceCount = uint32_t(gpuInstances.size());
  positions = createBufferWithData<glm::uvec2>(ctx, pos, kStorage, "surfel positions");
  attributes = createBufferWithData<glm::uvec2>(ctx, attr, kStorage, "surfel attributes");
  radii = createBufferWithData<float>(ctx, prefixRadii, kStorage, "surfel prefix radii");
  clouds = createBufferWithData<sio::SurfelRenderCloud>(ctx, gpuClouds, kStorage, "surfel clouds");
  instances = createBufferWithData<sio::SurfelRenderInstance>(ctx, gpuInstances, kStorage, "surfel instances");
  materials = createBufferWithData<sio::GpuMaterial>(ctx, gpuMaterials, kStorage, "surfel materials");
  return Ok{};
}

void SurfelRenderer::Impl::createPipelines() {
  textures = uploadTextures(ctx, Scene{}); // one white texel: the resolve samples no texture
  sampler = makeSampler(ctx, VK_FILTER_LINEAR);
  nearestSampler = makeSampler(ctx, VK_FILTER_NEAREST);
  VkDescriptorSetLayoutBinding bindings[] = {
      {0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
      {1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
      {2, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr}};
  descriptors = createDescriptorSet(ctx, bindings);
  VkDescriptorImageInfo white{sampler, textures[0].view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  writeImageDescriptors(ctx, descriptors.set, 0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, {&white, 1});

  layout = createPipelineLayout(ctx, {descriptors.layout.get()}, sizeof(sio::SurfelRenderPush), kPushStages);
  prefixPipeline = createComputePipeline(ctx, "surfel_render_prefix.comp", layout);
  scanPipeline = createComputePipeline(ctx, "surfel_render_scan.comp", layout);
  if (ctx.caps().int64BufferAtomics) {
    const uint32_t off[] = {VK_FALSE}, on[] = {VK_TRUE};
    for (int merge = 0; merge < 2; ++merge) {
      const char* shader = merge ? "surfel_render_splat_merge.comp" : "surfel_render_splat.comp";
      splatPipelines[merge][0] = createComputePipeline(ctx, shader, layout, off);
      splatPipelines[merge][1] = createComputePipeline(ctx, shader, layout, on);
    }
  }
  resolvePipeline = createComputePipeline(ctx, "surfel_render_resolve.comp", layout);
  GraphicsPipelineDesc d;
  d.vertexShader = "surfel_render_raster.vert";
  d.fragmentShader = "surfel_render_raster.frag";
  d.layout = layout;
  d.colorFormats = {kVisFormat};
  d.depthFormat = kDepthFormat;
  rasterPipeline = createGraphicsPipeline(ctx, d);

  frame = createBuffer(ctx, sizeof(sio::SurfelRenderFrame), kStorage, MemoryUsage::Upload, "surfel frame");
  states = createBuffer(ctx, uint64_t(instanceCount) * sizeof(sio::SurfelInstanceState),
                        kStorage | VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUsage::GpuOnly, "surfel states");
  batchInstance = createBuffer(ctx, std::max<uint64_t>(maxBatches, 1) * sizeof(uint32_t), kStorage,
                               MemoryUsage::GpuOnly, "surfel batch instances");
  draws = createBuffer(ctx, uint64_t(instanceCount) * sizeof(VkDrawIndirectCommand),
                       kStorage | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT, MemoryUsage::GpuOnly, "surfel draws");
  counters = createBuffer(ctx, sizeof(sio::SurfelRenderCounters),
                          kStorage | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                              VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                          MemoryUsage::GpuOnly, "surfel counters");
}

void SurfelRenderer::Impl::ensureTargets(uint32_t w, uint32_t h) {
  if (w == width && h == height) return;
  color = createImage2D(ctx, w, h, kColorFormat, VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                        "surfel color");
  vis =
      createImage2D(ctx, w, h, kVisFormat,
                    VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                    "surfel visibility");
  depth = createImage2D(ctx, w, h, kDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, "surfel depth");
  visBuffer = createBuffer(ctx, uint64_t(w) * h * 8,
                           kStorage | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                           MemoryUsage::GpuOnly, "surfel visibility64");
  VkDescriptorImageInfo visInfo{nearestSampler, vis.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  VkDescriptorImageInfo colorInfo{VK_NULL_HANDLE, color.view(), VK_IMAGE_LAYOUT_GENERAL};
  writeImageDescriptors(ctx, descriptors.set, 1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, {&visInfo, 1});
  writeImageDescriptors(ctx, descriptors.set, 2, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, {&colorInfo, 1});
  width = w;
  height = h;
}

sio::SurfelRenderPush SurfelRenderer::Impl::push() const {
  sio::SurfelRenderPush p{};
  p.frameAddress = frame.address();
  p.cloudAddress = clouds.address();
  p.instanceAddress = instances.address();
  p.stateAddress = states.address();
  p.positionAddress = positions.address();
  p.attributeAddress = attributes.address();
  p.materialAddress = materials.address();
  p.counterAddress = counters.address();
  p.drawAddress = draws.address();
  p.visBufferAddress = visBuffer.address();
  p.radiusAddress = radii.address();
  p.batchInstanceAddress = batchInstance.address();
  return p;
}

// barriers: on entry the counters were zeroed by a transfer and made visible to compute. On exit
// the instance states, draws and dispatch arguments are written and visible to the indirect,
// vertex, fragment and compute stages.
void SurfelRenderer::Impl::cmdPrefix(VkCommandBuffer cmd, const sio::SurfelRenderPush& p, GpuTimer& t) {
  uint32_t slot = t.cmdBegin(cmd, "prefix", kCS);
  vkCmdPushConstants(cmd, layout, kPushStages, 0, sizeof(p), &p);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, prefixPipeline);
  vkCmdDispatch(cmd, (instanceCount + MIRAGE_SURFEL_INSTANCE_WORKGROUP - 1) / MIRAGE_SURFEL_INSTANCE_WORKGROUP, 1, 1);
  cmdMemoryBarrier(cmd, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCS, kShaderRW);
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
void SurfelRenderer::Impl::cmdSplat(VkCommandBuffer cmd, SurfelRaster raster, GpuTimer& t) {
  uint32_t slot = t.cmdBegin(cmd, "splat");
  ImageBarrier toRead{vis.handle(),
                      VK_PIPELINE_STAGE_2_NONE,
                      0,
                      kCS | VK_PIPELINE_STAGE_2_COPY_BIT,
                      VK_ACCESS_2_SHADER_SAMPLED_READ_BIT | VK_ACCESS_2_TRANSFER_READ_BIT,
                      VK_IMAGE_LAYOUT_UNDEFINED,
                      VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  if (raster == SurfelRaster::Compute) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, splatPipelines[subgroupMerge][cullBackFaces]);
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
// resolve's writes available, which the readback expects.
void SurfelRenderer::Impl::cmdResolve(VkCommandBuffer cmd, const sio::SurfelRenderPush& p) {
  uint32_t slot = timer.cmdBegin(cmd, "resolve");
  cmdImageBarrier(cmd, {color.handle(), VK_PIPELINE_STAGE_2_NONE, 0, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                        VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL});
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, resolvePipeline);
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, layout, 0, 1, &descriptors.set, 0, nullptr);
  vkCmdPushConstants(cmd, layout, kPushStages, 0, sizeof(p), &p);
  vkCmdDispatch(cmd, (width + 7) / 8, (height + 7) / 8, 1);
  timer.cmdEnd(cmd, slot);
}

SurfelRenderer::SurfelRenderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
SurfelRenderer::~SurfelRenderer() = default;
const Bounds& SurfelRenderer::worldBounds() const { return impl_->worldBounds; }
uint64_t SurfelRenderer::surfelCount() const { return impl_->surfelCount; }
uint64_t SurfelRenderer::instancedCount() const { return impl_->instancedCount; }
SurfelOrder SurfelRenderer::order() const { return impl_->order; }

Result<std::unique_ptr<SurfelRenderer>> SurfelRenderer::create(Context& context, const SurfelScene& scene,
                                                               SurfelOrder order) {
  auto impl = std::make_unique<Impl>(context);
  impl->order = order;
  if (auto s = impl->upload(scene); !s) return s.error();
  impl->createPipelines();
  return std::unique_ptr<SurfelRenderer>(new SurfelRenderer(std::move(impl)));
}

Result<SurfelRenderOutput> SurfelRenderer::render(const SurfelRenderSettings& ss) {
  const RenderSettings& s = ss.base;
  if (s.width == 0 || s.height == 0 || s.width > kMaxRenderDimension || s.height > kMaxRenderDimension)
    return Error{fmt::format("render size {}x{} is outside 1..{}", s.width, s.height, kMaxRenderDimension)};
  if (!(ss.surfelSize >= 0.5f && ss.surfelSize <= 16.0f))
    return Error{fmt::format("--surfel-size {} must be in 0.5..16 pixels", ss.surfelSize)};
  Impl& d = *impl_;
  SurfelRaster raster = ss.raster == SurfelRaster::Auto
                            ? (d.ctx.caps().int64BufferAtomics ? SurfelRaster::Compute : SurfelRaster::Raster)
                            : ss.raster;
  if (raster == SurfelRaster::Compute && !d.ctx.caps().int64BufferAtomics)
    return Error{"--surfel-raster compute: the device has no 64-bit buffer atomics"};
  d.ensureTargets(s.width, s.height);

  Camera cam = withClipPlanes(s.camera, d.worldBounds);
  sio::SurfelRenderFrame f{};
  f.camera = viewFrame(cam, s.width, s.height);
  f.lightDir = glm::vec4(glm::normalize(s.lightDirection), s.lightIntensity);
  f.skyAmbient = glm::vec4(s.skyAmbient, 0.0f);
  f.groundAmbient = glm::vec4(s.groundAmbient, 0.0f);
  f.background = s.background;
  f.surfelSize = ss.surfelSize;
  f.fadeBand = std::max(ss.fadeBand, 0.0f);
  f.flags = (ss.frustumCulling ? MIRAGE_SURFEL_FRUSTUM_CULL : 0u) | (ss.allSurfels ? MIRAGE_SURFEL_ALL : 0u) |
            (raster == SurfelRaster::Compute ? MIRAGE_SURFEL_SOURCE_BUFFER : 0u) |
            (ss.meshFade ? MIRAGE_SURFEL_MESH_FADE : 0u) | (ss.backfaceCulling ? MIRAGE_SURFEL_BACKFACE_CULL : 0u) |
            mergeFlags(ss.merge) | (ss.orientedDiscs ? MIRAGE_SURFEL_ORIENTED : 0u);
  d.cullBackFaces = ss.backfaceCulling;
  d.subgroupMerge = ss.merge != SurfelMerge::Off;
  f.instanceCount = d.instanceCount;
  std::memcpy(d.frame.mapped(), &f, sizeof(f));
  sio::SurfelRenderPush p = d.push();

  // barriers: none on entry (one-shot submits wait) beyond ordering this frame's clears after any
  // earlier use of the same buffers.
  d.ctx.submitAndWait([&](VkCommandBuffer cmd) {
    d.timer.cmdReset(cmd);
    uint32_t frameSlot = d.timer.cmdBegin(cmd, "frame");
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                     VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                     VK_ACCESS_2_TRANSFER_WRITE_BIT);
    uint32_t clearSlot = d.timer.cmdBegin(cmd, "clear", VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT);
    vkCmdFillBuffer(cmd, d.counters.handle(), 0, VK_WHOLE_SIZE, 0);
    if (raster == SurfelRaster::Compute) vkCmdFillBuffer(cmd, d.visBuffer.handle(), 0, VK_WHOLE_SIZE, 0);
    d.timer.cmdEnd(cmd, clearSlot, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT);
    // Shaders reach these buffers through addresses, which synchronization validation does not
    // track: make the clears visible to every later reader directly.
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     kCS | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT, kShaderRW | VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT);
    d.cmdPrefix(cmd, p, d.timer);     // cull, k per instance, ids and batches, dispatch arguments
    d.cmdSplat(cmd, raster, d.timer); // visibility: (depth, surfel id) per pixel
    d.cmdResolve(cmd, p);             // fetch and shade
    d.timer.cmdEnd(cmd, frameSlot);
  });

  SurfelRenderOutput out;
  out.image.stats.passTimes = d.timer.read();
  out.raster = raster;
  sio::SurfelRenderCounters c{};
  std::vector<uint8_t> raw = readbackBuffer(d.ctx, d.counters, sizeof(c));
  std::memcpy(&c, raw.data(), sizeof(c));
  out.visibleInstances = c.visibleInstances;
  out.fadingInstances = c.fadingInstances;
  out.mergedInstances = raster == SurfelRaster::Compute && d.subgroupMerge ? c.mergedInstances : 0;
  out.surfelsSplatted = c.totalSurfels;
  out.image.stats.drawCalls = raster == SurfelRaster::Raster ? 1 : 0;
  if (ss.readInstanceStates) {
    std::vector<sio::SurfelInstanceState> st(d.instanceCount);
    raw = readbackBuffer(d.ctx, d.states, st.size() * sizeof(st[0]));
    std::memcpy(st.data(), raw.data(), raw.size());
    for (const auto& e : st) {
      out.prefix.push_back(e.count);
      out.fade.push_back(e.fade);
      out.distance.push_back(e.distance);
      out.merged.push_back(e.quantStep.w != 0.0f && d.subgroupMerge && raster == SurfelRaster::Compute ? 1 : 0);
    }
    out.idBuffer.resize(size_t(s.width) * s.height);
    if (raster == SurfelRaster::Compute) {
      raw = readbackBuffer(d.ctx, d.visBuffer, size_t(s.width) * s.height * 8);
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
  convertHalfImage(img, s.width, s.height, s.readLinear, out.image);
  return out;
}

Status SurfelRenderer::stagePrepare(const SurfelRenderSettings& ss, const SurfelStageFrame& sf) {
  Impl& d = *impl_;
  if (!d.ctx.caps().int64BufferAtomics) return Error{"mixed mesh/surfel rendering needs 64-bit buffer atomics"};
  if (!(ss.surfelSize >= 0.5f && ss.surfelSize <= 16.0f))
    return Error{fmt::format("--surfel-size {} must be in 0.5..16 pixels", ss.surfelSize)};
  // Surfel ids carry MIRAGE_SURFEL_ID_TAG, so the id space halves.
  if (d.instancedCount >= MIRAGE_SURFEL_ID_TAG) return Error{"mixed scene: more than 2^31 - 1 instanced surfels"};
  sio::SurfelRenderFrame f{};
  f.camera = sf.camera;
  f.surfelSize = ss.surfelSize;
  f.fadeBand = std::max(ss.fadeBand, 0.0f);
  f.flags = (ss.frustumCulling ? MIRAGE_SURFEL_FRUSTUM_CULL : 0u) | MIRAGE_SURFEL_SOURCE_BUFFER |
            (ss.meshFade ? MIRAGE_SURFEL_MESH_FADE : 0u) | (ss.backfaceCulling ? MIRAGE_SURFEL_BACKFACE_CULL : 0u) |
            mergeFlags(ss.merge) | (ss.orientedDiscs ? MIRAGE_SURFEL_ORIENTED : 0u);
  d.cullBackFaces = ss.backfaceCulling;
  d.subgroupMerge = ss.merge != SurfelMerge::Off;
  f.instanceCount = d.instanceCount;
  f.idTag = MIRAGE_SURFEL_ID_TAG;
  std::memcpy(d.frame.mapped(), &f, sizeof(f));
  d.stagePush = d.push();
  d.stagePush.visBufferAddress = sf.visBufferAddress;
  d.stagePush.meshFadeAddress = sf.meshFadeAddress;
  return Ok{};
}

void SurfelRenderer::stageCmdClear(VkCommandBuffer cmd) {
  vkCmdFillBuffer(cmd, impl_->counters.handle(), 0, VK_WHOLE_SIZE, 0);
}
void SurfelRenderer::stageCmdPrefix(VkCommandBuffer cmd, GpuTimer& timer) {
  impl_->cmdPrefix(cmd, impl_->stagePush, timer);
}
void SurfelRenderer::stageCmdSplat(VkCommandBuffer cmd, GpuTimer& timer) {
  // The cluster passes between the prefix and here pushed their own constants (another layout):
  // push ours again, else the splat reads the cluster push's addresses as its own.
  vkCmdPushConstants(cmd, impl_->layout, kPushStages, 0, sizeof(impl_->stagePush), &impl_->stagePush);
  impl_->cmdSplat(cmd, SurfelRaster::Compute, timer);
}

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

SurfelStageStats SurfelRenderer::stageStats() const {
  sio::SurfelRenderCounters c{};
  std::vector<uint8_t> raw = readbackBuffer(impl_->ctx, impl_->counters, sizeof(c));
  std::memcpy(&c, raw.data(), sizeof(c));
  return {c.visibleInstances, c.fadingInstances, c.totalSurfels};
}

} // namespace mirage::render
