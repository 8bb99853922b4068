// ClusterRenderer: the public API and the per-frame phase list (docs/render.md, "Passes"); the
// phases themselves live in the files cluster_impl.h lists.
#include <algorithm>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "cluster_impl.h"
#include "cluster_residency.h"
#include "render_util.h"
#include "mirage/gpu/commands.h"
#include "mirage/gpu/shaders.h"
#include "mirage/render/particle_draw.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

const char* toString(RasterBackend b) { return nameOf(kRasterBackendNames, b); }
Result<RasterBackend> parseRasterBackend(std::string_view text) {
  return parseNamed(text, "--raster", kRasterBackendNames);
}
const char* toString(BlendRaster b) { return nameOf(kBlendRasterNames, b); }
Result<BlendRaster> parseBlendRaster(std::string_view text) {
  return parseNamed(text, "--blend-raster", kBlendRasterNames);
}
const char* toString(StereoMode m) { return nameOf(kStereoModeNames, m); }
Result<StereoMode> parseStereoMode(std::string_view text) {
  return parseNamed(text, "--stereo-mode", kStereoModeNames);
}
const char* toString(SelectionMode m) { return nameOf(kSelectionModeNames, m); }
Result<SelectionMode> parseSelectionMode(std::string_view text) {
  return parseNamed(text, "--selection", kSelectionModeNames);
}

const char* toString(DebugView v) { return nameOf(kDebugViewNames, v); }
Result<DebugView> parseDebugView(std::string_view text) { return parseNamed(text, "--debug-view", kDebugViewNames); }

ClusterRenderer::ClusterRenderer(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
ClusterRenderer::~ClusterRenderer() = default;
const Bounds& ClusterRenderer::worldBounds() const { return impl_->scene.worldBounds; }
uint64_t ClusterRenderer::clusterCount() const { return impl_->scene.clusterCount; }

Status ClusterRenderer::setPvs(const lod::ClusterPvs* pvs) {
  Impl& d = *impl_;
  if (pvs && pvs->instanceBitOffset.size() != d.scene.instanceCount)
    return Error{fmt::format("cluster PVS for {} instances, the scene has {}", pvs->instanceBitOffset.size(),
                             d.scene.instanceCount)};
  if (pvs && pvs->clusterBits.size() * 4 > d.ctx.caps().maxStorageBufferRange)
    return Error{fmt::format("cluster PVS of {} bytes exceeds the device's storage buffer range", pvs->bytes())};
  // Frames recorded and not yet collected may still read the buffers replaced here: they live until
  // those slots complete (no device wait; a cell change happens while frames are in flight).
  d.retired.retire(std::move(d.pvsInstances), d.inFlightSlots());
  d.retired.retire(std::move(d.pvsClusters), d.inFlightSlots());
  d.retired.retire(std::move(d.pvsStaging), d.inFlightSlots());
  d.pvsInstances = {};
  d.pvsClusters = {};
  d.pvsStaging = {};
  if (!pvs) return Ok{};
  constexpr VkBufferUsageFlags kStorage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT;
  // Every instance culled still needs a cluster buffer with an address: one zero word.
  VkDeviceSize instanceBytes = pvs->instanceBitOffset.size() * 4,
               clusterBytes = std::max<size_t>(pvs->clusterBits.size(), 1) * 4;
  d.pvsInstances = createBuffer(d.ctx, instanceBytes, kStorage, MemoryUsage::GpuOnly, "pvs instances");
  d.pvsClusters = createBuffer(d.ctx, clusterBytes, kStorage, MemoryUsage::GpuOnly, "pvs cluster bits");
  d.pvsStaging = createBuffer(d.ctx, instanceBytes + clusterBytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                              MemoryUsage::Upload, "pvs staging");
  uint8_t* host = d.pvsStaging.mapped();
  std::memcpy(host, pvs->instanceBitOffset.data(), instanceBytes);
  std::memset(host + instanceBytes, 0, clusterBytes);
  std::memcpy(host + instanceBytes, pvs->clusterBits.data(), pvs->clusterBits.size() * 4);
  return Ok{};
}

ClusterRenderer::Impl::Impl(gpu::Context& c, ClusterSceneData s) : ctx(c), scene(std::move(s)) {
  for (uint32_t i = 0; i < kMaxFramesInFlight; ++i) timers.emplace_back(c, 48);
}
ClusterRenderer::Impl::~Impl() = default;

Result<std::unique_ptr<ClusterRenderer>> ClusterRenderer::create(Context& context, const lod::LodAsset& asset) {
  auto data = uploadClusterScene(context, asset);
  if (!data) return data.error();
  auto impl = std::make_unique<Impl>(context, std::move(*data));
  impl->createDescriptors();
  impl->createPipelines();
  return std::unique_ptr<ClusterRenderer>(new ClusterRenderer(std::move(impl)));
}

Result<std::unique_ptr<ClusterRenderer>> ClusterRenderer::create(Context& context, const lod::PagedLodAsset& asset,
                                                                 const ClusterResidencySettings& residency) {
  auto data = uploadPagedClusterScene(context, asset);
  if (!data) return data.error();
  auto r = createClusterResidency(context, asset, residency, *data);
  if (!r) return r.error();
  auto impl = std::make_unique<Impl>(context, std::move(data->scene));
  impl->residency = std::move(*r);
  impl->createDescriptors();
  impl->createPipelines();
  return std::unique_ptr<ClusterRenderer>(new ClusterRenderer(std::move(impl)));
}

Status ClusterRenderer::Impl::prepareFrame(const ClusterRenderSettings& cs, uint32_t frameSlot) {
  const uint64_t fixedKey = uint64_t(cs.base.width) | uint64_t(cs.base.height) << 16 |
                            uint64_t(cs.oitNodesPerPixel) << 32 | uint64_t(cs.stereoIpd.has_value()) << 40 |
                            uint64_t(std::isfinite(cs.blendQueuePixels)) << 41;
  if (fixedKey != oitFixedKey) oitFixedKey = fixedKey, oitPackedFrames = 0;
  auto planned = plan(cs);
  if (!planned) return planned.error();
  currentSlot = frameSlot;
  retired.completed(frameSlot); // a slot is recorded again only after its previous frame completed
  if (oitPackedFrames > 0) --oitPackedFrames;
  plans[currentSlot] = *planned;
  recorded[currentSlot] = false;
  if (residency)
    if (Status st = prepareResidency(cs); !st) return st;
  traversalDepth = planned->dagTree ? scene.dagDepth : scene.lodDepth;
  // New targets for a new size retire those frames in flight still use (no device wait).
  uint32_t colorW = planned->stereo ? cs.base.width * 2 : cs.base.width; // stereo: left|right
  ensureTargets(cs.base.width, cs.base.height, colorW);
  if (planned->particles) prepareParticles(*cs.particles); // lists, colours, sums before the frame names them
  ensureOitPool(cs.oitNodesPerPixel);
  plans[currentSlot].oitFixedSlots = planned->oitFixedSlots = fixedSlotsFor(*planned); // the pool is known now
  writeTargetDescriptors(currentSlot);
  if (planned->multiview) ensureMultiview(*planned);
  if (planned->debugView != DebugView::None && !debugResolvePipeline)
    debugResolvePipeline = createComputePipeline(ctx, "cluster_debug_resolve.comp", layout);
  if (planned->debugView == DebugView::Overdraw && planned->backend == RasterBackend::Mesh && !overdrawMeshPipeline)
    overdrawMeshPipeline = createVisPipeline(/*mesh=*/true, /*atomic=*/false, /*overdraw=*/true);
  if (planned->debugView == DebugView::Overdraw && planned->backend == RasterBackend::Indirect &&
      !overdrawIndirectPipeline)
    overdrawIndirectPipeline = createVisPipeline(/*mesh=*/false, /*atomic=*/false, /*overdraw=*/true);
  if (planned->debugView == DebugView::Overdraw && !overdrawCounts)
    overdrawCounts = createBuffer(ctx, uint64_t(colorWidth) * height * 4, // stereo: both eyes
                                  VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                  MemoryUsage::GpuOnly, "overdraw counts");
  return packFrame(cs, *planned);
}

// One frame's commands; prepareFrame ran for `currentSlot`.
// barriers: the first one orders this frame after all work submitted before it on the queue, so
// the GPU-only scratch every slot shares (counters, lists, queues, visibility, HZB, history, OIT
// lists, the targets) is never written while an earlier frame still reads it, and whatever an
// earlier frame wrote (the history of last frame's visible clusters) is visible. Per slot are only
// what the CPU touches while other frames run: the ClusterFrame upload, the counter readback and
// the timestamp queries. On exit the counters are in readbacks[currentSlot] (visible to the host)
// and the colour target is in GENERAL, written by the resolve or composite (compute shaders).
void ClusterRenderer::Impl::cmdFrame(VkCommandBuffer cmd, const ClusterRenderSettings& cs) {
  const ClusterFramePlan& plan = plans[currentSlot];
  bool hierarchy = plan.hierarchy, occlusion = plan.occlusion, mesh = ctx.caps().meshShader;
  sio::ClusterPush p = push();
  timer().cmdReset(cmd);
  uint32_t frameTime = timer().cmdBegin(cmd, "frame");
  if (pvsStaging) { // a new cell's PVS (setPvs), ordered before its readers by the barrier below
    VkDeviceSize instanceBytes = pvsInstances.size();
    VkBufferCopy instances{0, 0, instanceBytes}, clusters{instanceBytes, 0, pvsClusters.size()};
    vkCmdCopyBuffer(cmd, pvsStaging.handle(), pvsInstances.handle(), 1, &instances);
    vkCmdCopyBuffer(cmd, pvsStaging.handle(), pvsClusters.handle(), 1, &clusters);
    retired.retire(std::move(pvsStaging), 1u << currentSlot);
    pvsStaging = {};
  }
  // The counters are zeroed before the opening barrier, which then also orders the clear before
  // their users: one barrier less on the frame's chain of dependent steps (H100: each costs a few
  // us). The last frame's readback copy of them is ordered before the clear by finishFrame's final
  // barrier (transfer stages in its second scope).
  vkCmdFillBuffer(cmd, counters.handle(), 0, VK_WHOLE_SIZE, 0);
  cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                   VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                   VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
  // The other clears and uploads wait for the last frame's readers of their buffers (the opening
  // barrier); the phase barrier after them runs only if there are any.
  bool cleared = false;
  auto clear = [&](const Buffer& b) {
    vkCmdFillBuffer(cmd, b.handle(), 0, VK_WHOLE_SIZE, 0);
    cleared = true;
  };
  if (residency) { // this frame's pages, a cleared feedback
    cmdResidencyUpload(cmd);
    cleared = true;
  }
  if (hierarchy) clear(traversal);
  if (oitHeads) clear(oitHeads); // empty lists
  if (plan.packed) {
    oitNodesUnzeroed = true;                 // its keys stay in the pool
  } else if (oitNodes && oitNodesUnzeroed) { // lists: afterwards the composite leaves the pool zero
    clear(oitNodes);
    oitNodesUnzeroed = false;
  }
  if (plan.particles) { // their draw arguments (live counts)
    cs.particles->cmdPrepare(cmd);
    cleared = true;
  }
  if (plan.splat) clear(splatAccum); // the splat's sums
  if (plan.debugView == DebugView::Overdraw) clear(overdrawCounts);
  if (cs.surfels) { // instances without a cloud keep fade 0: meshes only
    clear(fade);
    cs.surfels->stageCmdClear(cmd);
  }
  if (cleared) cmdPhaseBarrier(cmd, mesh);
  if (cs.surfels) { // k and the fade per instance first: the mesh passes read the fade
    cs.surfels->stageCmdPrefix(cmd, timer());
    cmdPhaseBarrier(cmd, mesh);
  }
  cmdSelect(cmd, p, hierarchy); // instance cull; LOCALCUT + frustum + cones: pass-1 lists, candidates
  if (occlusion) {              // the select pass read last frame's history; the resolve writes this frame's
    vkCmdFillBuffer(cmd, history.handle(), 0, VK_WHOLE_SIZE, 0);
    cmdPhaseBarrier(cmd, mesh);
  }
  // Pass-1 raster arguments (everything without occlusion): the flat selection's last workgroup
  // writes them itself unless occlusion culling runs (cluster_select.comp).
  if (hierarchy || occlusion) cmdArgs(cmd, p, /*pass=*/0);
  bool blend = plan.transparency && plan.debugView == DebugView::None; // debug views: opaque surfaces only
  bool lists = blend || plan.particles;                                // the transparency lists composited
  if (plan.stereo) { // both eyes side by side, each pass once (docs/render.md, "Stereo")
    sio::ClusterPush eyes = p;
    eyes.frameAddress += kFrameStride; // the left eye's frame; the right eye's follows it
    cmdRasterize(cmd, eyes, plan.backend, 0);
    if (occlusion) { // one HZB over both eyes; a sphere is hidden only if hidden from both
      cmdBuildHzb(cmd, eyes);
      cmdOcclusion(cmd, p, hierarchy);
      cmdArgs(cmd, p, /*pass=*/1);
      cmdRasterize(cmd, eyes, plan.backend, 1);
    }
    if (cs.surfels) { // both eyes' halves of the 2W buffer, after the meshes as in mono
      cs.surfels->stageCmdSplat(cmd, timer());
      cmdPhaseBarrier(cmd, mesh);
    }
    if (blend) cmdArgs(cmd, p, /*pass=*/2);
    cmdResolve(cmd, eyes);
    if (lists) cmdTransparency(cmd, eyes, plan, blend, cs.particles);
    finishFrame(cmd, plan, frameTime);
    return;
  }
  cmdRasterize(cmd, p, plan.backend, 0); // visibility: (cluster, triangle) per pixel
  if (occlusion) {
    cmdBuildHzb(cmd, p);             // farthest-depth pyramid of pass 1
    cmdOcclusion(cmd, p, hierarchy); // pass-2 cull: candidates against the HZB
    cmdArgs(cmd, p, /*pass=*/1);
    cmdRasterize(cmd, p, plan.backend, 1); // the newly visible clusters
  }
  if (cs.surfels) { // after the meshes, so the HZB holds meshes only (as without surfels)
    cs.surfels->stageCmdSplat(cmd, timer());
    cmdPhaseBarrier(cmd, mesh);
  }
  if (blend) cmdArgs(cmd, p, /*pass=*/2); // the blend list is complete after both phases
  cmdResolve(cmd, p);                     // fetch, interpolate, shade; with occlusion: the clusters owning pixels
  if (lists)                              // blend raster and particles into fragment lists, sorted composite
    cmdTransparency(cmd, p, plan, blend, cs.particles);
  finishFrame(cmd, plan, frameTime);
}

// The frame's end: its time, and the counters (and traversal counters) into this slot's readback
// for collect().
void ClusterRenderer::Impl::finishFrame(VkCommandBuffer cmd, const ClusterFramePlan& plan, uint32_t frameTime) {
  bool hierarchy = plan.hierarchy, mesh = ctx.caps().meshShader;
  timer().cmdEnd(cmd, frameTime);
  cmdPhaseBarrier(cmd, mesh);
  if (plan.surfels) plan.surfels->stageCmdFinish(cmd); // the surfel stage's counters into its slot's readback
  VkBufferCopy countersRegion{0, 0, sizeof(sio::ClusterCounters)};
  vkCmdCopyBuffer(cmd, counters.handle(), readbacks[currentSlot].handle(), 1, &countersRegion);
  if (hierarchy) {
    VkBufferCopy traversalRegion{0, sizeof(sio::ClusterCounters), sizeof(sio::ClusterTraversal)};
    vkCmdCopyBuffer(cmd, traversal.handle(), readbacks[currentSlot].handle(), 1, &traversalRegion);
  }
  if (residency) cmdResidencyFeedback(cmd);
  // The host reads the copies; the next frame's counter clear (before its opening barrier) waits
  // for the copy that reads them.
  cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                   VK_PIPELINE_STAGE_2_HOST_BIT | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_HOST_READ_BIT);
  recorded[currentSlot] = true;
}

Status ClusterRenderer::record(VkCommandBuffer cmd, const ClusterRenderSettings& cs, uint32_t slot) {
  if (slot >= kMaxFramesInFlight)
    return Error{fmt::format("frame slot {} is outside 0..{}", slot, kMaxFramesInFlight - 1)};
  Impl& d = *impl_;
  if (Status st = d.prepareFrame(cs, slot); !st) return st.error();
  d.cmdFrame(cmd, cs);
  return Ok{};
}

Result<ClusterRenderOutput> ClusterRenderer::collect(uint32_t slot) {
  Impl& d = *impl_;
  if (slot >= kMaxFramesInFlight || !d.recorded[slot])
    return Error{fmt::format("frame slot {} holds no recorded frame", slot)};
  ClusterRenderOutput out;
  out.image.stats.passTimes = d.timers[slot].read();
  out.stats = d.readStats(slot);
  if (out.stats.oitFixedRedone) d.oitPackedFrames = kOitPackedFramesAfterOverflow;
  out.image.stats.drawCalls = 1;
  out.image.stats.trianglesSubmitted = out.stats.trianglesRasterized;
  if (d.plans[slot].surfels) out.stats.surfels = d.plans[slot].surfels->stageStats(slot);
  if (d.residency) out.stats.residency = d.collectResidency(slot);
  d.recorded[slot] = false;
  d.retired.completed(slot);
  return out;
}

const gpu::Image& ClusterRenderer::colorTarget() const { return impl_->color; }

Result<ClusterRenderOutput> ClusterRenderer::render(const ClusterRenderSettings& cs) {
  const RenderSettings& s = cs.base;
  Impl& d = *impl_;
  PhaseClock clock;
  if (Status st = d.prepareFrame(cs, 0); !st) return st.error();
  double prepareMs = clock.lap();
  d.ctx.submitAndWait([&](VkCommandBuffer cmd) { d.cmdFrame(cmd, cs); });
  double submitMs = clock.lap();
  auto collected = collect(0);
  if (!collected) return collected.error();
  ClusterRenderOutput out = std::move(*collected);
  ResidencyTimes& times = out.stats.residency.times; // residency frames: where the time went
  times.setupMs = std::max(prepareMs - (times.renderThreadMs() - times.collectMs), 0.0);
  times.submitMs = submitMs;
  times.collectMs = clock.lap();

  if (cs.readOwnedClusters) {
    // The resolve set bit (historyOffset + cluster) of every cluster owning a pixel this frame.
    std::vector<uint8_t> bits = readbackBuffer(d.ctx, d.history, (d.scene.instancedClusters + 31) / 32 * 4);
    const uint32_t* words = reinterpret_cast<const uint32_t*>(bits.data());
    uint64_t base = 0;
    for (uint32_t i = 0; i < d.scene.instanceCount; base += d.scene.instanceClusters[i++])
      for (uint32_t k = 0; k < d.scene.instanceClusters[i]; ++k)
        if ((words[(base + k) / 32] >> ((base + k) % 32)) & 1u) out.ownedClusters.emplace_back(i, k);
  }
  if (cs.readVisibility) {
    std::vector<uint8_t> pixels = readbackBuffer(d.ctx, d.visBuffer, size_t(d.colorWidth) * d.height * 8);
    std::vector<uint8_t> listBytes = readbackBuffer(d.ctx, d.visible, size_t(d.visibleCapacity) * 8);
    std::vector<sio::VisibleCluster> list(d.visibleCapacity);
    std::memcpy(list.data(), listBytes.data(), listBytes.size());
    // With residency the list names record slots: their clusters from the drawn pages' records.
    std::unordered_map<uint32_t, uint32_t> slotClusters;
    if (d.residency) slotClusters = drawnSlotClusters(*d.residency);
    out.visibility.resize(size_t(d.colorWidth) * d.height);
    for (size_t i = 0; i < out.visibility.size(); ++i) {
      uint64_t value;
      std::memcpy(&value, pixels.data() + i * 8, 8);
      uint32_t id = uint32_t(value), entry = id >> MIRAGE_CLUSTER_TRIANGLE_BITS;
      VisibilitySample& v = out.visibility[i];
      v.depthBits = uint32_t(value >> 32);
      if (entry == 0 || entry > list.size() || (id & MIRAGE_SURFEL_ID_TAG) != 0) continue;
      v.instance = list[entry - 1].instance;
      v.cluster = list[entry - 1].cluster;
      if (d.residency) {
        auto it = slotClusters.find(v.cluster);
        v.cluster = it == slotClusters.end() ? UINT32_MAX : it->second;
      }
      v.triangle = id & ((1u << MIRAGE_CLUSTER_TRIANGLE_BITS) - 1u);
    }
  }
  if (s.readImage) {
    std::vector<uint8_t> img = readbackImage(d.ctx, d.color, VK_IMAGE_LAYOUT_GENERAL, 8);
    convertHalfImage(img, d.colorWidth, s.height, s.readLinear, out.image);
  }
  times.readbackMs = clock.lap();
  return out;
}

} // namespace mirage::render
