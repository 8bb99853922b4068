// SurfelRenderer: names, the coherent order, upload, pipelines and targets (docs/surfels.md,
// "Rendering"); the per-frame commands are in surfel_frame.cpp.
#include "mirage/render/surfel_renderer.h"

#include <algorithm>
#include <cstring>
#include <numeric>
#include <unordered_map>

#include <fmt/format.h>

#include "render_util.h"
#include "surfel_impl.h"
#include "mirage/gpu/commands.h"
#include "mirage/gpu/descriptors.h"
#include "mirage/gpu/pipeline.h"
#include "mirage/gpu/query.h"
#include "mirage/shaderio/surfel_render.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

namespace {

constexpr VkBufferUsageFlags kStorage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;

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

Status SurfelRenderer::Impl::upload(const SurfelScene& scene) {
  if (scene.clouds.empty() || scene.instances.empty()) return Error{"surfel scene has no clouds or no instances"};
  std::vector<glm::uvec2> pos, attr;
  std::vector<float> prefixRadii;
  std::vector<sio::SurfelRenderCloud> gpuClouds;
  std::vector<Material> cloudMaterials;
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
    g.material = uint32_t(cloudMaterials.size());
    g.coherentMinBlock = coherentMinBlock(order);
    gpuClouds.push_back(g);
    Material m = c.material;
    m.baseColorTexture = m.metallicRoughnessTexture = m.normalTexture = m.occlusionTexture = m.emissiveTexture = -1;
    cloudMaterials.push_back(m);
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
  materials = uploadMaterials(ctx, cloudMaterials, 0, mapTransforms, "surfel materials");
  resolveSpecialization = materialMapSpecialization(cloudMaterials, 0);
  lights = uploadLights(ctx, scene.lights, "surfel point lights");
  lightCount = uint32_t(scene.lights.size());
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
  // One set per slot (identically defined layouts are compatible): a slot's targets are written
  // into its own set when it is recorded, while other slots' frames may still read theirs.
  VkDescriptorImageInfo white{sampler, textures[0].view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  for (DescriptorSet& set : descriptors) {
    set = createDescriptorSet(ctx, bindings);
    writeImageDescriptors(ctx, set.set, 0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, {&white, 1});
  }

  layout = createPipelineLayout(ctx, {descriptors[0].layout.get()}, sizeof(sio::SurfelRenderPush), kSurfelPushStages);
  prefixPipeline = createComputePipeline(ctx, "surfel_render_prefix.comp", layout);
  scanPipeline = createComputePipeline(ctx, "surfel_render_scan.comp", layout);
  resolvePipeline = createComputePipeline(ctx, "surfel_render_resolve.comp", layout, resolveSpecialization);
  GraphicsPipelineDesc d;
  d.vertexShader = "surfel_render_raster.vert";
  d.fragmentShader = "surfel_render_raster.frag";
  d.layout = layout;
  d.colorFormats = {kSurfelVisFormat};
  d.depthFormat = kSurfelDepthFormat;
  rasterPipeline = createGraphicsPipeline(ctx, d);

  for (uint32_t i = 0; i < kMaxFramesInFlight; ++i) {
    frames[i] = createBuffer(ctx, sizeof(sio::SurfelRenderFrame), kStorage, MemoryUsage::Upload, "surfel frame");
    readbacks[i] = createBuffer(ctx, sizeof(sio::SurfelRenderCounters), VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                MemoryUsage::Readback, "surfel counters readback");
  }
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

// The compute splat of the plan (created on first use: the stereo variants only when stereo runs).
VkPipeline SurfelRenderer::Impl::splatPipeline(const SurfelFramePlan& plan) {
  Unique<VkPipeline>& p = splatPipelines[plan.subgroupMerge][plan.cullBackFaces][plan.eyes == 2];
  if (!p) {
    const uint32_t specialization[] = {plan.cullBackFaces ? VK_TRUE : VK_FALSE, plan.eyes};
    p = createComputePipeline(ctx, plan.subgroupMerge ? "surfel_render_splat_merge.comp" : "surfel_render_splat.comp",
                              layout, specialization);
  }
  return p;
}

uint32_t SurfelRenderer::Impl::inFlightSlots() const {
  uint32_t slots = 0;
  for (uint32_t i = 0; i < kMaxFramesInFlight; ++i)
    if (recorded[i]) slots |= 1u << i;
  return slots;
}

// New targets for a new size: the replaced ones live until every slot recorded and not yet
// collected completed (no device wait; each slot's descriptor set names its own frame's targets).
void SurfelRenderer::Impl::ensureTargets(uint32_t w, uint32_t h, uint32_t colorW) {
  if (w == width && h == height && colorW == colorWidth) return;
  uint32_t inFlight = inFlightSlots();
  retired.retire(std::move(color), inFlight);
  retired.retire(std::move(vis), inFlight);
  retired.retire(std::move(depth), inFlight);
  retired.retire(std::move(visBuffer), inFlight);
  color = createImage2D(ctx, colorW, h, kSurfelColorFormat,
                        VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT, "surfel color");
  vis =
      createImage2D(ctx, w, h, kSurfelVisFormat,
                    VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT | VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT,
                    "surfel visibility");
  depth = createImage2D(ctx, w, h, kSurfelDepthFormat, VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT, "surfel depth");
  visBuffer = createBuffer(ctx, uint64_t(colorW) * h * 8,
                           kStorage | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                           MemoryUsage::GpuOnly, "surfel visibility64");
  width = w;
  height = h;
  colorWidth = colorW;
}

// The slot's previous frame completed (the caller's contract), so its set may be rewritten.
void SurfelRenderer::Impl::writeDescriptors(uint32_t slot) {
  VkDescriptorImageInfo visInfo{nearestSampler, vis.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  VkDescriptorImageInfo colorInfo{VK_NULL_HANDLE, color.view(), VK_IMAGE_LAYOUT_GENERAL};
  writeImageDescriptors(ctx, descriptors[slot].set, 1, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, {&visInfo, 1});
  writeImageDescriptors(ctx, descriptors[slot].set, 2, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, {&colorInfo, 1});
}

sio::SurfelRenderPush SurfelRenderer::Impl::push() const {
  sio::SurfelRenderPush p{};
  p.frameAddress = frames[currentSlot].address();
  p.cloudAddress = clouds.address();
  p.instanceAddress = instances.address();
  p.stateAddress = states.address();
  p.positionAddress = positions.address();
  p.attributeAddress = attributes.address();
  p.materialAddress = materials.address();
  p.counterAddress = counters.address();
  p.drawAddress = draws.address();
  p.visBufferAddress = visBuffer ? visBuffer.address() : 0;
  p.radiusAddress = radii.address();
  p.batchInstanceAddress = batchInstance.address();
  return p;
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

} // namespace mirage::render
