// ClusterRenderer: the public API and the per-frame phase list (docs/render.md, "Passes"); the
// phases themselves live in the files cluster_impl.h lists.
#include <fmt/format.h>

#include "cluster_impl.h"
#include "render_util.h"
#include "mirage/gpu/commands.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

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
  case RasterBackend::Hybrid:
    return "hybrid";
  }
  return "?";
}

Result<RasterBackend> parseRasterBackend(std::string_view text) {
  return parseNamed(text, "--raster",
                    {RasterBackend::Auto, RasterBackend::Mesh, RasterBackend::Indirect, RasterBackend::Compute,
                     RasterBackend::Hybrid});
}

const char* toString(BlendRaster b) {
  switch (b) {
  case BlendRaster::Auto:
    return "auto";
  case BlendRaster::Compute:
    return "compute";
  case BlendRaster::Hybrid:
    return "hybrid";
  case BlendRaster::Hardware:
    return "hardware";
  }
  return "?";
}

Result<BlendRaster> parseBlendRaster(std::string_view text) {
  return parseNamed(text, "--blend-raster",
                    {BlendRaster::Auto, BlendRaster::Compute, BlendRaster::Hybrid, BlendRaster::Hardware});
}

const char* toString(SelectionMode m) {
  switch (m) {
  case SelectionMode::Auto:
    return "auto";
  case SelectionMode::Flat:
    return "flat";
  case SelectionMode::Hierarchy:
    return "hierarchy";
  case SelectionMode::Dag:
    return "dag";
  }
  return "?";
}

Result<SelectionMode> parseSelectionMode(std::string_view text) {
  return parseNamed(text, "--selection",
                    {SelectionMode::Auto, SelectionMode::Flat, SelectionMode::Hierarchy, SelectionMode::Dag});
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

Result<ClusterRenderOutput> ClusterRenderer::render(const ClusterRenderSettings& cs) {
  const RenderSettings& s = cs.base;
  Impl& d = *impl_;
  auto planned = d.plan(cs);
  if (!planned) return planned.error();
  const ClusterFramePlan& plan = *planned;
  bool hierarchy = plan.hierarchy, occlusion = plan.occlusion;
  d.traversalDepth = plan.dagTree ? d.scene.dagDepth : d.scene.lodDepth;
  d.ensureTargets(s.width, s.height);
  if (Status st = d.packFrame(cs, plan); !st) return st.error();
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
    if (plan.bufferTarget) vkCmdFillBuffer(cmd, d.visBuffer.handle(), 0, VK_WHOLE_SIZE, 0);
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
    d.cmdArgs(cmd, p, /*pass=*/0);           // pass-1 raster arguments (everything without occlusion)
    d.cmdRasterize(cmd, p, plan.backend, 0); // visibility: (cluster, triangle) per pixel
    if (occlusion) {
      d.cmdBuildHzb(cmd, p);             // farthest-depth pyramid of pass 1
      d.cmdOcclusion(cmd, p, hierarchy); // pass-2 cull: candidates against the HZB
      d.cmdArgs(cmd, p, /*pass=*/1);
      d.cmdRasterize(cmd, p, plan.backend, 1); // the newly visible clusters
    }
    if (cs.surfels) { // after the meshes, so the HZB holds meshes only (as without surfels)
      cs.surfels->stageCmdSplat(cmd, d.timer);
      cmdPhaseBarrier(cmd, d.ctx.caps().meshShader);
    }
    if (d.hasBlend()) d.cmdArgs(cmd, p, /*pass=*/2); // the blend list is complete after both phases
    d.cmdResolve(cmd, p); // fetch, interpolate, shade; with occlusion: the clusters owning pixels
    if (d.hasBlend())     // blend raster into fragment lists, sorted composite
      d.cmdTransparency(cmd, p, plan.blend, plan.meshBlend, plan.bufferTarget);
    d.timer.cmdEnd(cmd, frameSlot);
  });

  ClusterRenderOutput out;
  out.image.stats.passTimes = d.timer.read();
  out.stats = d.readStats(cs, plan);
  out.image.stats.drawCalls = 1;
  out.image.stats.trianglesSubmitted = out.stats.trianglesRasterized;

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
