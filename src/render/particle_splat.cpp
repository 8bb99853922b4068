// The splat of small particles (render/particle_draw.h, docs/particles.md "Splat"): one compute
// thread per record slot; a particle under the threshold adds its coverage to the weighted blended
// sums of the pixels its footprint overlaps (particle_splat.glsl), a larger one is listed for the
// billboards. After the transparency composite the sums are resolved over the colour.
#include <algorithm>
#include <cstring>

#include "mirage/gpu/commands.h"
#include "particle_draw_impl.h"
#include "render_util.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

namespace {

// The accumulation that runs: float adds where asked or available, else fixed point.
bool useFixedPoint(const ParticleDrawSettings& s, const DeviceCapabilities& caps) {
  if (s.atomics == SplatAtomics::Fixed) return true;
  if (s.atomics == SplatAtomics::Float) return false;
  return !caps.floatBufferAtomicAdd;
}

} // namespace

bool ParticleDraw::splats(OitMode mode) const {
  const Impl& d = *impl_;
  const DeviceCapabilities& caps = d.ctx.caps();
  return mode != OitMode::Sorted && d.settings.splatBelowPixels > 0.0f && !d.batches.empty() &&
         (caps.floatBufferAtomicAdd || caps.int64BufferAtomics);
}

uint64_t ParticleDraw::splatBytes(uint64_t pixels) const {
  bool fixed = useFixedPoint(impl_->settings, impl_->ctx.caps());
  return std::max<uint64_t>(pixels, 1) * MIRAGE_SPLAT_CHANNELS * (fixed ? 8 : 4);
}

sio::ParticleSplatPush ParticleDraw::Impl::splatPush(const ParticleSplatTarget& t) const {
  sio::ParticleSplatPush p{};
  p.frameAddress[0] = t.frames[0];
  p.frameAddress[1] = t.eyes > 1 ? t.frames[1] : t.frames[0];
  p.batchAddress = batchTable.address();
  p.argsAddress = indirect.address();
  p.accumAddress = t.accumulators->address();
  p.largeAddress = largeList.address();
  p.largeArgsAddress = largeArgs.address();
  p.total = totalRecords;
  p.batchCount = uint32_t(batches.size());
  p.eyes = t.eyes;
  p.eyeWidth = t.eyeWidth;
  p.height = t.height;
  p.belowPixels = settings.splatBelowPixels;
  p.fixedPoint = fixedPoint ? 1u : 0u;
  return p;
}

// barriers: see particle_draw.h; the accumulators zeroed by a transfer, the depth in
// DEPTH_READ_ONLY_OPTIMAL with its writes visible to compute shaders (the renderer's transition).
void ParticleDraw::cmdSplat(VkCommandBuffer cmd, const ParticleSplatTarget& t) {
  Impl& d = *impl_;
  if (!splats(OitMode::LinkedList)) return; // the mode was checked by the caller (splats(mode))
  d.ensureComputeLayout();
  d.fixedPoint = useFixedPoint(d.settings, d.ctx.caps());
  Unique<VkPipeline>& pipeline = d.splatPipelines[d.fixedPoint];
  if (!pipeline)
    pipeline = createComputePipeline(d.ctx, d.fixedPoint ? "particle_splat_fixed.comp" : "particle_splat_float.comp",
                                     d.computeLayout);
  if (!d.splatResolvePipeline) {
    d.splatResolvePipeline = createComputePipeline(d.ctx, "particle_splat_resolve.comp", d.computeLayout);
    d.depthSampler = makeSampler(d.ctx, VK_FILTER_NEAREST);
    d.largeArgs = createBuffer(d.ctx, sizeof(VkDrawIndirectCommand),
                               VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT |
                                   VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                               MemoryUsage::GpuOnly, "particle billboard list draw");
  }
  // The list has a slot per record (grown only here: more records come with no frame in flight).
  if (!d.largeList || d.largeList.size() < uint64_t(std::max(d.totalRecords, 1u)) * 4)
    d.largeList = createBuffer(d.ctx, uint64_t(std::max(d.totalRecords, 1u)) * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                               MemoryUsage::GpuOnly, "particle billboard list");
  // The slot's set: its previous frame completed (the renderer's slot contract).
  VkDescriptorSet set = d.frameSets[t.slot % kMaxFramesInFlight].set;
  VkDescriptorImageInfo depthInfo{d.depthSampler, t.depth, VK_IMAGE_LAYOUT_DEPTH_READ_ONLY_OPTIMAL};
  VkDescriptorImageInfo colorInfo{VK_NULL_HANDLE, t.color, VK_IMAGE_LAYOUT_GENERAL};
  writeImageDescriptors(d.ctx, set, 0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, {&depthInfo, 1});
  writeImageDescriptors(d.ctx, set, 1, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, {&colorInfo, 1});

  VkDrawIndirectCommand empty{6, 0, 0, 0};
  vkCmdUpdateBuffer(cmd, d.largeArgs.handle(), 0, sizeof(empty), &empty);
  cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, kCS, kStorageRW);
  VkDescriptorSet sets[] = {d.descriptors.set, set};
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.computeLayout, 0, 2, sets, 0, nullptr);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
  sio::ParticleSplatPush push = d.splatPush(t);
  vkCmdPushConstants(cmd, d.computeLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
  d.cmdDispatchRecords(cmd);
  cmdMemoryBarrier(cmd, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | VK_PIPELINE_STAGE_2_VERTEX_SHADER_BIT | kCS,
                   VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
  d.splatRecorded = true;
}

void ParticleDraw::cmdSplatResolve(VkCommandBuffer cmd, const ParticleSplatTarget& t) {
  Impl& d = *impl_;
  if (!d.splatRecorded) return;
  cmdMemoryBarrier(cmd, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCS, kStorageRW); // the composite's colour
  VkDescriptorSet sets[] = {d.descriptors.set, d.frameSets[t.slot % kMaxFramesInFlight].set};
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.computeLayout, 0, 2, sets, 0, nullptr);
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.splatResolvePipeline);
  sio::ParticleSplatPush push = d.splatPush(t);
  vkCmdPushConstants(cmd, d.computeLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
  vkCmdDispatch(cmd, (t.eyes * t.eyeWidth + 7) / 8, (t.height + 7) / 8, 1);
}

uint32_t ParticleDraw::readBillboardCount() {
  Impl& d = *impl_;
  if (!d.largeArgs) return 0;
  std::vector<uint8_t> bytes = readbackBuffer(d.ctx, d.largeArgs, sizeof(VkDrawIndirectCommand));
  VkDrawIndirectCommand c{};
  std::memcpy(&c, bytes.data(), sizeof(c));
  return c.instanceCount;
}

} // namespace mirage::render
