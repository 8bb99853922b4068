// Particle billboards inside the renderers' transparency passes (render/particle_draw.h,
// docs/particles.md "Rendering"). One indirect draw per batch: 6 vertices, one instance per
// record, the instance count copied from the simulation's live counter before the pass.
#include <algorithm>
#include <cstring>

#include <fmt/format.h>

#include "forward_impl.h"
#include "mirage/gpu/commands.h"
#include "mirage/shaderio/cluster.h"
#include "particle_draw_impl.h"
#include "render_util.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

// The billboards read the eye's camera from the frame address either renderer passes.
static_assert(offsetof(sio::FrameData, camera) == 0 && offsetof(sio::ClusterFrame, camera) == 0,
              "ParticleDrawPush::frameAddress names a ViewFrame");

ParticleDraw::ParticleDraw(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ParticleDraw::~ParticleDraw() = default;

Result<std::unique_ptr<ParticleDraw>> ParticleDraw::create(Context& context, std::span<const ParticleSheet> sheets) {
  if (sheets.empty()) return Error{"particle draw: no texture sheet"};
  auto d = std::make_unique<Impl>(context);
  for (const ParticleSheet& s : sheets) {
    if (s.image.width == 0 || s.image.height == 0 ||
        s.image.pixels.size() != size_t(s.image.width) * s.image.height * 4)
      return Error{"particle draw: an empty or malformed texture sheet"};
    if (s.tilesX == 0 || s.tilesY == 0) return Error{"particle draw: a texture sheet of zero tiles"};
    uint32_t mips = mipLevelCount(s.image.width, s.image.height);
    VkImageCreateInfo ci{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
    ci.imageType = VK_IMAGE_TYPE_2D;
    ci.format = VK_FORMAT_R8G8B8A8_UNORM; // coverage, not colour: linear
    ci.extent = {s.image.width, s.image.height, 1};
    ci.mipLevels = mips;
    ci.arrayLayers = 1;
    ci.samples = VK_SAMPLE_COUNT_1_BIT;
    ci.usage = VK_IMAGE_USAGE_SAMPLED_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT;
    Image img = createImage(context, ci, VK_IMAGE_ASPECT_COLOR_BIT, "particle sheet");
    uploadTextureRGBA8(context, img, s.image.pixels.data(), s.image.width, s.image.height, mips);
    d->sheetImages.push_back(std::move(img));
    d->sheets.push_back({ImageRGBA8{}, s.tilesX, s.tilesY, s.alphaFromGreyscale});
  }
  // Clamped: a tile's border texels must not blend with the neighbouring tile's far side.
  VkSamplerCreateInfo si{VK_STRUCTURE_TYPE_SAMPLER_CREATE_INFO};
  si.magFilter = si.minFilter = VK_FILTER_LINEAR;
  si.mipmapMode = VK_SAMPLER_MIPMAP_MODE_LINEAR;
  si.addressModeU = si.addressModeV = si.addressModeW = VK_SAMPLER_ADDRESS_MODE_CLAMP_TO_EDGE;
  si.maxLod = VK_LOD_CLAMP_NONE;
  VkSampler sampler;
  MIRAGE_VK_CHECK(vkCreateSampler(context.device(), &si, nullptr, &sampler));
  d->sampler = Unique<VkSampler>(context.device(), sampler);
  VkDescriptorSetLayoutBinding binding{0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, uint32_t(sheets.size()),
                                       VK_SHADER_STAGE_FRAGMENT_BIT | VK_SHADER_STAGE_COMPUTE_BIT, nullptr};
  d->descriptors = createDescriptorSet(context, {&binding, 1});
  std::vector<VkDescriptorImageInfo> infos;
  for (const Image& img : d->sheetImages)
    infos.push_back({d->sampler, img.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL});
  writeImageDescriptors(context, d->descriptors.set, 0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, infos);
  d->layout = createPipelineLayout(context, {d->descriptors.layout.get()}, sizeof(sio::ParticleDrawPush),
                                   VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT);
  d->batchCapacity = 16; // grown by cmdPrepare for more batches
  constexpr VkBufferUsageFlags kArgs =
      VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  d->indirect = createBuffer(context, d->batchCapacity * sizeof(VkDrawIndirectCommand), kArgs, MemoryUsage::GpuOnly,
                             "particle draw arguments");
  d->batchTable = createBuffer(context, d->batchCapacity * sizeof(sio::ParticleBatchInfo), kArgs, MemoryUsage::GpuOnly,
                               "particle batches");
  return std::unique_ptr<ParticleDraw>(new ParticleDraw(std::move(d)));
}

Status ParticleDraw::setSettings(const ParticleDrawSettings& settings) {
  if (!(settings.splatBelowPixels >= 0.0f && settings.splatBelowPixels <= MIRAGE_SPLAT_MAX_PIXELS))
    return Error{fmt::format("particle splat threshold {} px: must be in 0..{}", settings.splatBelowPixels,
                             MIRAGE_SPLAT_MAX_PIXELS)};
  if (uint32_t n = settings.splatBinSlots; n > MIRAGE_SPLAT_BIN_SLOTS || (n & (n - 1)) != 0)
    return Error{
        fmt::format("particle splat bin slots {}: must be a power of two of at most {}", n, MIRAGE_SPLAT_BIN_SLOTS)};
  const DeviceCapabilities& caps = impl_->ctx.caps();
  if (settings.atomics == SplatAtomics::Float && !caps.floatBufferAtomicAdd)
    return Error{"particle splat: the device has no float atomic adds (shaderBufferFloat32AtomicAdd)"};
  if (settings.atomics == SplatAtomics::Fixed && !caps.int64BufferAtomics)
    return Error{"particle splat: the device has no 64-bit buffer atomics"};
  impl_->settings = settings;
  return Ok{};
}

const ParticleDrawSettings& ParticleDraw::settings() const { return impl_->settings; }

// The compute passes' layout: the sheets (set 0), per frame slot the target's depth and colour
// (set 1), and the largest of their push constants.
void ParticleDraw::Impl::ensureComputeLayout() {
  if (computeLayout) return;
  VkDescriptorSetLayoutBinding bindings[] = {
      {0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
      {1, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr}};
  for (DescriptorSet& set : frameSets) set = createDescriptorSet(ctx, bindings);
  computeLayout = createPipelineLayout(
      ctx, {descriptors.layout.get(), frameSets[0].layout.get()},
      uint32_t(std::max(sizeof(sio::ParticleSortPush), sizeof(sio::ParticleSplatPush))), VK_SHADER_STAGE_COMPUTE_BIT);
}

void ParticleDraw::Impl::cmdDispatchRecords(VkCommandBuffer cmd, uint32_t perThread) const {
  uint64_t perGroup = uint64_t(MIRAGE_PARTICLE_DRAW_GROUP) * perThread;
  uint32_t groups = std::max<uint32_t>(uint32_t((totalRecords + perGroup - 1) / perGroup), 1);
  gpu::DispatchRows rows = gpu::dispatchRows(groups);
  vkCmdDispatch(cmd, rows.x, rows.y, 1);
}

void ParticleDraw::setBatches(std::vector<ParticleBatch> batches) {
  impl_->batches = std::move(batches);
  uint64_t total = 0;
  for (const ParticleBatch& b : impl_->batches) total += b.count;
  impl_->totalRecords = uint32_t(std::min<uint64_t>(total, UINT32_MAX));
}

void ParticleDraw::setCpuBatches(std::span<const CpuBatch> batches) {
  Impl& d = *impl_;
  size_t total = 0;
  for (const CpuBatch& b : batches) total += b.records.size();
  uint64_t bytes = std::max<uint64_t>(total, 1) * sizeof(sio::RenderParticle);
  if (!d.cpuRecords || d.cpuRecords.size() < bytes)
    d.cpuRecords =
        createBuffer(d.ctx, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::Upload, "particle records");
  d.batches.clear();
  size_t at = 0;
  for (const CpuBatch& b : batches) {
    if (!b.records.empty())
      std::memcpy(static_cast<uint8_t*>(d.cpuRecords.mapped()) + at * sizeof(sio::RenderParticle), b.records.data(),
                  b.records.size_bytes());
    d.batches.push_back({d.cpuRecords.address() + at * sizeof(sio::RenderParticle), VK_NULL_HANDLE, 0,
                         uint32_t(b.records.size()), b.sheet});
    at += b.records.size();
  }
  d.totalRecords = uint32_t(total);
}

size_t ParticleDraw::batchCount() const { return impl_->batches.size(); }

void ParticleDraw::cmdPrepare(VkCommandBuffer cmd) {
  Impl& d = *impl_;
  d.splatRecorded = false; // this frame's cmdDraw draws every record unless cmdSplat runs
  if (d.batches.empty()) return;
  if (d.batchCapacity < d.batches.size()) { // rare: more batches than ever before
    d.batchCapacity = uint32_t(d.batches.size());
    constexpr VkBufferUsageFlags kArgs =
        VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
    d.indirect = createBuffer(d.ctx, d.batchCapacity * sizeof(VkDrawIndirectCommand), kArgs, MemoryUsage::GpuOnly,
                              "particle draw arguments");
    d.batchTable = createBuffer(d.ctx, d.batchCapacity * sizeof(sio::ParticleBatchInfo), kArgs, MemoryUsage::GpuOnly,
                                "particle batches");
  }
  std::vector<VkDrawIndirectCommand> args;
  std::vector<sio::ParticleBatchInfo> table;
  uint32_t first = 0;
  for (const ParticleBatch& b : d.batches) {
    args.push_back({6, b.countBuffer ? 0 : b.count, 0, 0});
    const ParticleSheet& s = d.sheetOf(b);
    table.push_back({b.records, first, b.count, std::min<uint32_t>(b.sheet, uint32_t(d.sheets.size() - 1)), s.tilesX,
                     s.tilesY, s.alphaFromGreyscale ? MIRAGE_PARTICLE_ALPHA_FROM_GREY : 0u});
    first += b.count;
  }
  vkCmdUpdateBuffer(cmd, d.indirect.handle(), 0, args.size() * sizeof(args[0]), args.data());
  vkCmdUpdateBuffer(cmd, d.batchTable.handle(), 0, table.size() * sizeof(table[0]), table.data());
  cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
  // The live counts of GPU batches, as the simulation left them (its writes ordered by the
  // frame's first barrier), into instanceCount.
  for (uint32_t i = 0; i < d.batches.size(); ++i) {
    if (!d.batches[i].countBuffer) continue;
    VkBufferCopy copy{d.batches[i].countOffset, i * sizeof(VkDrawIndirectCommand) + 4, 4};
    vkCmdCopyBuffer(cmd, d.batches[i].countBuffer, d.indirect.handle(), 1, &copy);
  }
  cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT |
                       VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT,
                   VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
}

VkPipeline ParticleDraw::Impl::pipeline(OitMode mode) {
  Unique<VkPipeline>& p = pipelines[size_t(mode)];
  if (p) return p;
  GraphicsPipelineDesc g;
  g.vertexShader = "particle_billboard.vert";
  g.layout = layout;
  g.depthFormat = kForwardDepthFormat;
  g.depthWrite = false; // tested against the opaque depth; particles never occlude each other
  if (mode == OitMode::LinkedList) {
    g.fragmentShader = "particle_billboard_oit.frag"; // no colour output: the lists are the result
  } else if (mode == OitMode::Weighted) {
    g.fragmentShader = "particle_billboard_weighted.frag";
    g.colorFormats = {kForwardAccumFormat, kForwardAccumFormat};
    g.colorBlends = {forwardWeightedBlend(), forwardWeightedBlend()};
  } else {
    g.fragmentShader = "particle_billboard.frag";
    g.colorFormats = {kForwardColorFormat};
    g.alphaBlend = true;
  }
  p = createGraphicsPipeline(ctx, g);
  return p;
}

sio::ParticleDrawPush ParticleDraw::Impl::drawPush(VkDeviceAddress frame, VkDeviceAddress oitLists) const {
  sio::ParticleDrawPush push{};
  push.frameAddress = frame;
  push.oitAddress = oitLists;
  push.batchAddress = batchTable.address();
  push.batchCount = uint32_t(batches.size());
  return push;
}

// The pipeline of `mode` with the sheets bound, facing state for billboards turned either way.
void ParticleDraw::Impl::cmdBindDraw(VkCommandBuffer cmd, OitMode mode) {
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline(mode));
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, layout, 0, 1, &descriptors.set, 0, nullptr);
  vkCmdSetCullMode(cmd, VK_CULL_MODE_NONE); // rotated billboards may face either way
  vkCmdSetFrontFace(cmd, VK_FRONT_FACE_COUNTER_CLOCKWISE);
}

void ParticleDraw::cmdDraw(VkCommandBuffer cmd, OitMode mode, VkDeviceAddress frame, VkDeviceAddress oitLists) {
  Impl& d = *impl_;
  if (d.batches.empty()) return;
  d.cmdBindDraw(cmd, mode);
  if (d.splatRecorded) { // the particles the splat left: one draw over every batch's
    sio::ParticleDrawPush push = d.drawPush(frame, mode == OitMode::LinkedList ? oitLists : 0);
    push.recordAddress = d.largeList.address();
    push.mode = MIRAGE_PARTICLE_DRAW_INDICES;
    vkCmdPushConstants(cmd, d.layout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(push),
                       &push);
    vkCmdDrawIndirect(cmd, d.largeArgs.handle(), 0, 1, sizeof(VkDrawIndirectCommand));
    return;
  }
  for (uint32_t i = 0; i < d.batches.size(); ++i) {
    const ParticleBatch& b = d.batches[i];
    const ParticleSheet& s = d.sheetOf(b);
    sio::ParticleDrawPush push = d.drawPush(frame, mode == OitMode::LinkedList ? oitLists : 0);
    push.recordAddress = b.records;
    push.sheet = std::min<uint32_t>(b.sheet, uint32_t(d.sheets.size() - 1));
    push.tilesX = s.tilesX;
    push.tilesY = s.tilesY;
    push.flags = s.alphaFromGreyscale ? MIRAGE_PARTICLE_ALPHA_FROM_GREY : 0u;
    push.mode = MIRAGE_PARTICLE_DRAW_RECORDS;
    vkCmdPushConstants(cmd, d.layout, VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT, 0, sizeof(push),
                       &push);
    vkCmdDrawIndirect(cmd, d.indirect.handle(), i * sizeof(VkDrawIndirectCommand), 1, sizeof(VkDrawIndirectCommand));
  }
}

} // namespace mirage::render
