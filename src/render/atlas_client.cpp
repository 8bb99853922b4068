// The thin client's renderer, CPU side (docs/stream.md, "The client's renderer"): creation, the patch slots (an id ->
// slot map, a free list, the slots changed since the last frame) and the atlas uploads queued for
// the next frame. Nothing here waits for the device: the next recorded frame uploads the changes.
#include <algorithm>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "atlas_client_impl.h"
#include "mirage/gpu/commands.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

namespace {

constexpr uint32_t kMaxClientPatches = 1u << 24;

uint32_t alphaFlag(PatchAlpha alpha) {
  switch (alpha) {
  case PatchAlpha::Mask:
    return MIRAGE_ALPHA_MASK;
  case PatchAlpha::Blend:
    return MIRAGE_ALPHA_BLEND;
  default:
    return MIRAGE_ALPHA_OPAQUE;
  }
}

bool isBlend(const sio::GpuClientPatch& p) {
  return p.triangleCount != 0 && (p.flags & MIRAGE_CLIENT_ALPHA_MASK) == MIRAGE_ALPHA_BLEND;
}

Status checkPatch(uint32_t id, const ClientPatch& p, const AtlasClientConfig& config) {
  if (p.triangleCount < 1 || p.triangleCount > MIRAGE_ATLAS_MAX_PATCH_TRIANGLES)
    return Error{
        fmt::format("patch {}: {} triangles, outside 1..{}", id, p.triangleCount, MIRAGE_ATLAS_MAX_PATCH_TRIANGLES)};
  for (uint32_t v = 0; v < p.triangleCount + 2; ++v)
    if (!std::isfinite(p.positions[v].x) || !std::isfinite(p.positions[v].y) || !std::isfinite(p.positions[v].z))
      return Error{fmt::format("patch {}: vertex {} is not a finite position", id, "abcde"[v])};
  if (p.colorOnly) return Ok{};
  if (p.blockLog2 < MIRAGE_ATLAS_MIN_BLOCK_LOG2 || p.blockLog2 > MIRAGE_ATLAS_MAX_BLOCK_LOG2)
    return Error{fmt::format("patch {}: block log2 {} outside {}..{}", id, p.blockLog2, MIRAGE_ATLAS_MIN_BLOCK_LOG2,
                             MIRAGE_ATLAS_MAX_BLOCK_LOG2)};
  uint64_t w = sio::atlasBlockWidth(p.triangleCount, p.blockLog2), h = 1u << p.blockLog2;
  if (p.blockX + w > config.atlasWidth || p.blockY + h > config.atlasHeight)
    return Error{fmt::format("patch {}: block {}x{} at ({}, {}) is outside the {}x{} atlas", id, w, h, p.blockX,
                             p.blockY, config.atlasWidth, config.atlasHeight)};
  return Ok{};
}

sio::GpuClientPatch toGpuPatch(const ClientPatch& p) {
  sio::GpuClientPatch g{};
  for (uint32_t v = 0; v < MIRAGE_ATLAS_MAX_PATCH_VERTICES; ++v)
    g.positions[v] = v < p.triangleCount + 2 ? p.positions[v] : p.positions[0];
  g.triangleCount = p.triangleCount;
  g.flags = alphaFlag(p.alpha) | (p.colorOnly ? MIRAGE_CLIENT_COLOR_ONLY : 0u);
  if (!p.colorOnly) g.blockX = p.blockX, g.blockY = p.blockY, g.blockLog2 = p.blockLog2;
  g.color = p.color;
  return g;
}

} // namespace

void AtlasClientRenderer::Impl::createResources() {
  patches = createBuffer(ctx, uint64_t(config.maxPatches) * sizeof(sio::GpuClientPatch),
                         VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::GpuOnly,
                         "client patches");
  atlas = createImage2D(ctx, config.atlasWidth, config.atlasHeight, kAtlasFormat,
                        VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT, "atlas");
  // Bilinear, clamped, no mips: the atlas layout keeps every tap inside its block (shaderio/atlas.h).
  VkSamplerCreateInfo si{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  si.magFilter = si.minFilter = VK_FILTER_LINEAR;
  si.mipmapMode = VK_SAMPLER_MIPMAP_MODE_NEAREST;
  si.addressModeU = si.addressModeV = si.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  si.maxLod = 0.0f;
  VkSampler s;
  MIRAGE_VK_CHECK(vkCreateSampler(ctx.device(), &si, nullptr, &s));
  sampler = Unique<VkSampler>(ctx.device(), s);

  VkDescriptorSetLayoutBinding atlasBinding{0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1,
                                            VK_SHADER_STAGE_FRAGMENT_BIT, nullptr};
  atlasDescriptors = createDescriptorSet(ctx, {&atlasBinding, 1});
  VkDescriptorImageInfo atlasInfo{sampler, atlas.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL};
  writeImageDescriptors(ctx, atlasDescriptors.set, 0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, {&atlasInfo, 1});

  layout = createPipelineLayout(ctx, {atlasDescriptors.layout.get()}, sizeof(sio::AtlasClientPush),
                                VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT);
  GraphicsPipelineDesc d;
  d.vertexShader = "atlas_client.vert";
  d.fragmentShader = "atlas_client.frag";
  d.layout = layout;
  d.colorFormats = {kClientColorFormat};
  d.depthFormat = kClientDepthFormat;
  opaquePipeline = createGraphicsPipeline(ctx, d);
  d.fragmentShader = "atlas_client_oit.frag"; // no colour output: the lists are the result
  d.colorFormats = {};
  d.depthWrite = false; // blended patches test against the opaque depth, do not occlude each other
  appendPipeline = createGraphicsPipeline(ctx, d);
  d.vertexShader = "atlas_client_particle.vert"; // the particles join the same lists
  d.fragmentShader = "atlas_client_particle.frag";
  particlePipeline = createGraphicsPipeline(ctx, d);

  // The forward renderer's resolve, as is: binding 0 the colour target, the lists by address.
  VkDescriptorSetLayoutBinding colorBinding{0, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT,
                                            nullptr};
  for (uint32_t i = 0; i < kMaxFramesInFlight; ++i) {
    resolveDescriptors[i] = createDescriptorSet(ctx, {&colorBinding, 1});
    frames[i] = createBuffer(ctx, sizeof(sio::ViewFrame), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::Upload,
                             "client frame");
    oitLists[i] =
        createBuffer(ctx, sizeof(sio::OitLists), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::Upload, "oit lists");
    oitReadback[i] = createBuffer(ctx, sizeof(sio::OitCounters), VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                  MemoryUsage::Readback, "oit counters readback");
  }
  resolveLayout = createPipelineLayout(ctx, {resolveDescriptors[0].layout.get()}, sizeof(sio::ForwardResolvePush),
                                       VK_SHADER_STAGE_COMPUTE_BIT);
  resolvePipeline = createComputePipeline(ctx, "forward_oit_resolve.comp", resolveLayout);
  oitCounters = createBuffer(ctx, sizeof(sio::OitCounters),
                             VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                                 VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                             MemoryUsage::GpuOnly, "oit counters");
}

void AtlasClientRenderer::Impl::markDirty(uint32_t slot) {
  if (dirtyFlag[slot]) return;
  dirtyFlag[slot] = 1;
  dirty.push_back(slot);
}

AtlasClientRenderer::AtlasClientRenderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
AtlasClientRenderer::~AtlasClientRenderer() = default;

Result<std::unique_ptr<AtlasClientRenderer>> AtlasClientRenderer::create(Context& context,
                                                                         const AtlasClientConfig& config) {
  if (config.atlasWidth == 0 || config.atlasHeight == 0 || config.atlasWidth > kMaxRenderDimension ||
      config.atlasHeight > kMaxRenderDimension)
    return Error{
        fmt::format("atlas size {}x{} is outside 1..{}", config.atlasWidth, config.atlasHeight, kMaxRenderDimension)};
  if (config.maxPatches == 0 || config.maxPatches > kMaxClientPatches)
    return Error{fmt::format("{} patch slots are outside 1..{}", config.maxPatches, kMaxClientPatches)};
  auto impl = std::make_unique<Impl>(context, config);
  impl->createResources();
  return std::unique_ptr<AtlasClientRenderer>(new AtlasClientRenderer(std::move(impl)));
}

Status AtlasClientRenderer::setPatch(uint32_t id, const ClientPatch& patch) {
  Impl& d = *impl_;
  if (Status st = checkPatch(id, patch, d.config); !st) return st.error();
  auto it = d.slotOf.find(id);
  uint32_t slot;
  if (it != d.slotOf.end()) {
    slot = it->second;
  } else if (!d.freeSlots.empty()) {
    slot = d.freeSlots.back();
    d.freeSlots.pop_back();
  } else if (d.slots.size() < d.config.maxPatches) {
    slot = uint32_t(d.slots.size());
    d.slots.push_back({});
    d.dirtyFlag.push_back(0);
  } else {
    return Error{fmt::format("patch {}: all {} patch slots are in use", id, d.config.maxPatches)};
  }
  d.slotOf[id] = slot;
  sio::GpuClientPatch& g = d.slots[slot];
  d.blendPatches -= isBlend(g);
  d.patchTriangles -= g.triangleCount;
  g = toGpuPatch(patch);
  d.blendPatches += isBlend(g);
  d.patchTriangles += g.triangleCount;
  for (uint32_t v = 0; v < patch.triangleCount + 2; ++v) d.bounds.add(patch.positions[v]);
  d.markDirty(slot);
  return Ok{};
}

Status AtlasClientRenderer::removePatch(uint32_t id) {
  Impl& d = *impl_;
  auto it = d.slotOf.find(id);
  if (it == d.slotOf.end()) return Error{fmt::format("patch {} is not set", id)};
  uint32_t slot = it->second;
  d.slotOf.erase(it);
  sio::GpuClientPatch& g = d.slots[slot];
  d.blendPatches -= isBlend(g);
  d.patchTriangles -= g.triangleCount;
  g = {}; // triangleCount 0: the slot draws nothing
  d.freeSlots.push_back(slot);
  d.markDirty(slot);
  return Ok{};
}

size_t AtlasClientRenderer::patchCount() const { return impl_->slotOf.size(); }

Status AtlasClientRenderer::setParticles(std::span<const ClientParticle> particles) {
  Impl& d = *impl_;
  std::vector<sio::GpuClientParticle> records;
  records.reserve(particles.size());
  for (size_t i = 0; i < particles.size(); ++i) {
    const ClientParticle& p = particles[i];
    if (!std::isfinite(p.position.x) || !std::isfinite(p.position.y) || !std::isfinite(p.position.z) ||
        !std::isfinite(p.size) || !std::isfinite(p.rotation))
      return Error{fmt::format("particle {}: a position, size or rotation that is not finite", i)};
    sio::GpuClientParticle g{p.position, p.size, p.rotation, p.color, p.lookColor, 0};
    if (!p.colorOnly) {
      if (p.blockLog2 < MIRAGE_ATLAS_MIN_BLOCK_LOG2 || p.blockLog2 > MIRAGE_ATLAS_MAX_BLOCK_LOG2)
        return Error{fmt::format("particle {}: block log2 {} outside {}..{}", i, p.blockLog2,
                                 MIRAGE_ATLAS_MIN_BLOCK_LOG2, MIRAGE_ATLAS_MAX_BLOCK_LOG2)};
      uint64_t side = 1u << p.blockLog2;
      if (p.blockX + 2 * side > d.config.atlasWidth || p.blockY + side > d.config.atlasHeight)
        return Error{fmt::format("particle {}: block {}x{} at ({}, {}) is outside the {}x{} atlas", i, 2 * side, side,
                                 p.blockX, p.blockY, d.config.atlasWidth, d.config.atlasHeight)};
      g.block = p.blockX | p.blockY << 16;
      g.blockLog2 = p.blockLog2;
    }
    records.push_back(g);
  }
  d.particles = std::move(records);
  for (const ClientParticle& p : particles) { // clip planes (never shrink)
    d.bounds.add(p.position - glm::vec3(p.size));
    d.bounds.add(p.position + glm::vec3(p.size));
  }
  return Ok{};
}

size_t AtlasClientRenderer::particleCount() const { return impl_->particles.size(); }

Status AtlasClientRenderer::updateAtlas(const ImageRGBA8& image) {
  Impl& d = *impl_;
  if (image.width != d.config.atlasWidth || image.height != d.config.atlasHeight ||
      image.pixels.size() != size_t(image.width) * image.height * 4)
    return Error{fmt::format("atlas image {}x{} ({} bytes) does not match the {}x{} atlas", image.width, image.height,
                             image.pixels.size(), d.config.atlasWidth, d.config.atlasHeight)};
  // Replaces every texel: the uploads queued before it are dropped rather than copied for nothing.
  d.pendingRegions.clear();
  d.pendingTexels.clear();
  return updateAtlasRegion(0, 0, image.width, image.height, image.pixels.data());
}

Status AtlasClientRenderer::updateAtlasRegion(uint32_t x, uint32_t y, uint32_t width, uint32_t height,
                                              const uint8_t* rgba8) {
  Impl& d = *impl_;
  if (width == 0 || height == 0 || uint64_t(x) + width > d.config.atlasWidth ||
      uint64_t(y) + height > d.config.atlasHeight)
    return Error{fmt::format("atlas region {}x{} at ({}, {}) is empty or outside the {}x{} atlas", width, height, x, y,
                             d.config.atlasWidth, d.config.atlasHeight)};
  if (!rgba8) return Error{"atlas region without texels"};
  size_t bytes = size_t(width) * height * 4;
  d.pendingRegions.push_back({x, y, width, height, d.pendingTexels.size()});
  d.pendingTexels.insert(d.pendingTexels.end(), rgba8, rgba8 + bytes);
  return Ok{};
}

} // namespace mirage::render
