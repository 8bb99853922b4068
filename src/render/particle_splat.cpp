// The splat of small particles (render/particle_draw.h, docs/particles.md "Splat"): one compute
// thread per record slot; a particle under the threshold adds its coverage to the weighted blended
// sums of the pixels its footprint overlaps (particle_splat.glsl), a larger one is listed for the
// billboards. Binned: the splats counted per screen tile, the counts scanned, the splats scattered
// into their tiles' lists, and one workgroup per chunk of a tile's list sums them in shared memory
// and writes the tile once; otherwise each pixel's sums take global atomics per particle. After the transparency
// composite the sums are resolved over the colour.
#include <algorithm>
#include <bit>
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

// Auto takes the bins: the per-pixel atomics are bound by the rate of global atomics (on an H100,
// 200 M float atomic adds to distinct addresses of an L2-resident buffer take 2.3 ms by
// themselves, 10 M particles of 1 px times 4 pixels times 5 sums), where the bins take one shared
// 32-bit atomic per sum and word and a global atomic per workgroup and tile.
bool useBins(const ParticleDrawSettings& s) { return s.splatMethod != SplatMethod::Atomic; }

constexpr uint64_t kRecordsPerBinGroup = uint64_t(MIRAGE_PARTICLE_DRAW_GROUP) * MIRAGE_SPLAT_BIN_RECORDS;
constexpr uint64_t kBinTableBytes = MIRAGE_SPLAT_BIN_SLOTS * sizeof(glm::uvec2); // a uvec2 per slot
constexpr uint64_t kEntryBytes = MIRAGE_SPLAT_ENTRY_BYTES;

uint32_t tilesAcross(uint32_t pixels) { return (pixels + MIRAGE_SPLAT_TILE - 1) / MIRAGE_SPLAT_TILE; }

void cmdComputeToCompute(VkCommandBuffer cmd) {
  cmdMemoryBarrier(cmd, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCS, kStorageRW);
}

} // namespace

bool ParticleDraw::splatsBinned() const { return useBins(impl_->settings); }

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
  p.binAddress = bins ? bins.address() : 0;
  p.entryAddress = entries ? entries.address() : 0;
  p.entryRoom = entryRoom;
  p.tableAddress = tables ? tables.address() : 0;
  p.tilesX = tilesAcross(t.eyeWidth);
  p.tilesY = tilesAcross(t.height);
  p.binSlotBits =
      settings.splatBinSlots ? uint32_t(std::countr_zero(settings.splatBinSlots)) : MIRAGE_SPLAT_BIN_SLOT_BITS;
  return p;
}

// barriers: the classification's inputs as cmdSplat's; on exit the sums' writes are the tile
// pass's (cmdSplat's closing barrier covers them).
void ParticleDraw::Impl::cmdSplatBinned(VkCommandBuffer cmd, sio::ParticleSplatPush push, gpu::GpuTimer* timer) {
  // Each pass inside `name`'s timestamps where a timer is given.
  auto timed = [&](const char* name, auto&& record) {
    uint32_t slot = timer ? timer->cmdBegin(cmd, name, kCS) : UINT32_MAX;
    record();
    if (timer) timer->cmdEnd(cmd, slot, kCS);
  };
  int fixed = fixedPoint ? 1 : 0;
  if (!binPipelines[fixed]) {
    binPipelines[fixed] = createComputePipeline(
        ctx, fixedPoint ? "particle_splat_bin_fixed.comp" : "particle_splat_bin_float.comp", computeLayout);
    tilePipelines[fixed] = createComputePipeline(
        ctx, fixedPoint ? "particle_splat_tiles_fixed.comp" : "particle_splat_tiles_float.comp", computeLayout);
  }
  if (!scanPipeline) scanPipeline = createComputePipeline(ctx, "particle_splat_scan.comp", computeLayout);
  // Count: every splat's entries per tile (the counts zeroed by cmdSplat).
  push.phase = MIRAGE_SPLAT_PHASE_COUNT;
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, binPipelines[fixed]);
  vkCmdPushConstants(cmd, computeLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
  timed("splat-count", [&] { cmdDispatchRecords(cmd, MIRAGE_SPLAT_BIN_RECORDS); });
  cmdComputeToCompute(cmd);
  // Scan: the tiles' first entries and chunks, the cursors zeroed, the tile pass's dispatch.
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, scanPipeline);
  timed("splat-scan", [&] { vkCmdDispatch(cmd, 1, 1, 1); });
  cmdMemoryBarrier(cmd, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, kCS | VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT,
                   kStorageRW | VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT);
  // Scatter: the entries into their tiles' lists (past the room: added directly).
  push.phase = MIRAGE_SPLAT_PHASE_SCATTER;
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, binPipelines[fixed]);
  vkCmdPushConstants(cmd, computeLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
  timed("splat-scatter", [&] { cmdDispatchRecords(cmd, MIRAGE_SPLAT_BIN_RECORDS); });
  cmdComputeToCompute(cmd);
  // Tiles: one workgroup per chunk of a tile's list, its sums written once.
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, tilePipelines[fixed]);
  timed("splat-tiles", [&] { vkCmdDispatchIndirect(cmd, bins.handle(), 0); });
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

  const bool binned = useBins(d.settings);
  if (binned) {
    // The bins: per tile of either eye a count, a first entry and a first chunk, and the header;
    // made for at least two eyes of 4096 x 4096 (1.6 MB), so that no usual resize replaces them
    // under a frame in flight.
    uint64_t tiles = uint64_t(t.eyes) * tilesAcross(t.eyeWidth) * tilesAcross(t.height);
    uint64_t binBytes = (MIRAGE_SPLAT_BIN_HEADER + 3 * tiles + 2) * 4;
    uint64_t minTiles = 2 * uint64_t(tilesAcross(4096)) * tilesAcross(4096);
    if (!d.bins || d.bins.size() < binBytes)
      d.bins = createBuffer(d.ctx, std::max(binBytes, (MIRAGE_SPLAT_BIN_HEADER + 3 * minTiles + 2) * 4),
                            VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT |
                                VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                            MemoryUsage::GpuOnly, "particle splat bins");
    // The entries: the setting's room, or a default per record slot (either eye count: grown only
    // with the records, which grow with no frame in flight), within one buffer's range.
    uint64_t room = d.settings.splatEntryRoom
                        ? d.settings.splatEntryRoom
                        : uint64_t(std::max(d.totalRecords, 1u)) * MIRAGE_SPLAT_ENTRIES_PER_RECORD;
    room = std::min<uint64_t>({room, d.ctx.caps().maxStorageBufferRange / kEntryBytes, UINT32_MAX});
    if (!d.entries || d.entries.size() < room * kEntryBytes)
      d.entries = createBuffer(d.ctx, room * kEntryBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::GpuOnly,
                               "particle splat entries");
    d.entryRoom = uint32_t(room);
    // Per count workgroup its tile table, which its scatter workgroup reads instead of counting again.
    uint64_t groups = (uint64_t(std::max(d.totalRecords, 1u)) + kRecordsPerBinGroup - 1) / kRecordsPerBinGroup;
    if (!d.tables || d.tables.size() < groups * kBinTableBytes)
      d.tables = createBuffer(d.ctx, groups * kBinTableBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::GpuOnly,
                              "particle splat bin tables");
    vkCmdFillBuffer(cmd, d.bins.handle(), 0, binBytes, 0);
  }
  VkDrawIndirectCommand empty{6, 0, 0, 0};
  vkCmdUpdateBuffer(cmd, d.largeArgs.handle(), 0, sizeof(empty), &empty);
  cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, kCS, kStorageRW);
  VkDescriptorSet sets[] = {d.descriptors.set, set};
  vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.computeLayout, 0, 2, sets, 0, nullptr);
  sio::ParticleSplatPush push = d.splatPush(t);
  if (binned) {
    d.cmdSplatBinned(cmd, push, t.timer);
  } else {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
    vkCmdPushConstants(cmd, d.computeLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
    d.cmdDispatchRecords(cmd);
  }
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
