// One cluster frame's data: the settings resolved against the device and scene (the plan), the
// camera and plan packed into ClusterFrame, and the GPU counters turned into ClusterStats.
#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>

#include <fmt/format.h>

#include "cluster_impl.h"
#include "mirage/gpu/commands.h"
#include "mirage/render/oit.h"
#include "mirage/render/particle_draw.h"
#include "mirage/shaderio/debug_view.h"
#include "mirage/shaderio/lod_error.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

static_assert(uint32_t(DebugView::Clusters) == MIRAGE_DEBUG_VIEW_CLUSTERS &&
                  uint32_t(DebugView::Lod) == MIRAGE_DEBUG_VIEW_LOD &&
                  uint32_t(DebugView::Density) == MIRAGE_DEBUG_VIEW_DENSITY &&
                  uint32_t(DebugView::Overdraw) == MIRAGE_DEBUG_VIEW_OVERDRAW,
              "DebugView numbers are ClusterFrame::debugView's");

namespace {

// The backend that runs: auto prefers hybrid (compute for small triangles, mesh shaders for large),
// then compute alone, then mesh shaders, then indirect draws.
Result<RasterBackend> resolveBackend(RasterBackend requested, const DeviceCapabilities& caps) {
  // The compute rasterizers need both (cluster_raster.glsl: the buffer, the tile queue).
  bool atomics = caps.int64BufferAtomics && caps.int64SharedAtomics,
       fragmentAtomics = atomics && caps.fragmentStoresAndAtomics;
  if (requested == RasterBackend::Auto)
    return fragmentAtomics && caps.meshShader ? RasterBackend::Hybrid
           : atomics                          ? RasterBackend::Compute
           : caps.meshShader                  ? RasterBackend::Mesh
                                              : RasterBackend::Indirect;
  if (requested == RasterBackend::Mesh && !caps.meshShader)
    return Error{"--raster mesh: the device has no VK_EXT_mesh_shader"};
  if (requested == RasterBackend::Compute && !atomics)
    return Error{"--raster compute: the device has no 64-bit buffer and shared atomics"};
  if (requested == RasterBackend::Hybrid && !fragmentAtomics)
    return Error{"--raster hybrid: the device has no 64-bit buffer atomics in fragment shaders"};
  return requested;
}

// The blend raster that runs. Auto is compute where the blend queue can run (64-bit buffer
// atomics): with large triangles spread over the GPU by the queue and small ones walked by their
// cluster's workgroup, no cluster pays the hardware raster's per-cluster mesh-shader set-up or
// per-fragment shader launch, and no depth copy runs (docs/render.md, "Blend rasters": the
// commands that measure the three). Without the queue auto is hybrid, as measured on the H200:
// the city's large glass at street level took 15.0 ms by compute, 0.28 hybrid, 0.25 hardware;
// 2500 AlphaBlendModeTest copies (5000 small clusters) 0.179 by compute, 0.393 hardware, and
// hybrid sends them all to compute. Hardware needs fragment stores and atomics (the list append),
// else auto falls back to compute.
Result<BlendRaster> resolveBlendRaster(BlendRaster requested, const DeviceCapabilities& caps) {
  bool hardware = caps.fragmentStoresAndAtomics;
  if (requested == BlendRaster::Auto)
    return caps.int64BufferAtomics ? BlendRaster::Compute : hardware ? BlendRaster::Hybrid : BlendRaster::Compute;
  if (requested != BlendRaster::Compute && !hardware)
    return Error{fmt::format("--blend-raster {}: the device has no stores and atomics in fragment shaders",
                             toString(requested))};
  return requested;
}

// Stereo through multiview for the backends that rasterize in a render pass (mesh, indirect, and
// hybrid's hardware list); the compute raster draws both eyes in one dispatch either way, so it is
// reported as viewports (its hardware blend draws, if any, take them). The overdraw view's counting
// pipelines exist only for per-eye viewports. Hybrid's list goes through mesh shaders where the
// device has them; without multiviewMeshShader auto keeps them (viewports), while multiview asked
// for draws the list by indirect draws instead (hybridListMesh).
Result<StereoMode> resolveStereoMode(StereoMode requested, const ClusterFramePlan& p, const DeviceCapabilities& caps) {
  bool can = p.backend != RasterBackend::Compute && caps.multiview &&
             (p.backend != RasterBackend::Mesh || caps.multiviewMeshShader) && p.debugView != DebugView::Overdraw;
  if (requested == StereoMode::Multiview && !can)
    return Error{
        fmt::format("--stereo-mode multiview: --raster {} cannot use it on this device ({})", toString(p.backend),
                    p.backend == RasterBackend::Compute  ? "the compute raster draws both eyes in one dispatch"
                    : !caps.multiview                    ? "no multiview"
                    : p.debugView == DebugView::Overdraw ? "the overdraw view counts per eye viewport"
                                                         : "no multiview for mesh shaders (multiviewMeshShader)")};
  // Auto is per-eye viewports: on the H100 multiview measured slower (2500 blobs, 2064x2208 per
  // eye, mesh 4.94 vs 3.64 ms a frame), its layers' copy into the side-by-side target alone taking
  // 1.29 ms (docs/render.md, "Stereo").
  return requested == StereoMode::Multiview ? StereoMode::Multiview : StereoMode::Viewports;
}

} // namespace

Result<ClusterFramePlan> ClusterRenderer::Impl::plan(const ClusterRenderSettings& cs) const {
  const RenderSettings& s = cs.base;
  if (s.width == 0 || s.height == 0 || s.width > kMaxRenderDimension || s.height > kMaxRenderDimension)
    return Error{fmt::format("render size {}x{} is outside 1..{}", s.width, s.height, kMaxRenderDimension)};
  if (!(cs.tauPixels > 0.0f)) return Error{fmt::format("--tau {} must be a positive number of pixels", cs.tauPixels)};
  if (!(cs.hybridThreshold >= 0.0f))
    return Error{fmt::format("--hybrid-threshold {} must be a non-negative number of pixels", cs.hybridThreshold)};
  if (cs.oitNodesPerPixel > 64) // 0: the renderer's default
    return Error{fmt::format("OIT node pool of {} nodes per pixel is outside 1..64", cs.oitNodesPerPixel)};
  if (cs.oit != OitMode::Fixed && cs.oit != OitMode::Packed && cs.oit != OitMode::LinkedList)
    return Error{fmt::format("--oit {}: cluster LOD scenes draw BLEND materials by fixed, packed or linked-list",
                             toString(cs.oit))};
  if (!(cs.blendQueuePixels >= 0.0f))
    return Error{fmt::format("--blend-queue-pixels {} must be a non-negative number of pixels", cs.blendQueuePixels)};
  ClusterFramePlan p;
  auto resolved = resolveBackend(cs.raster, ctx.caps());
  if (!resolved) return resolved.error();
  p.backend = *resolved;
  auto blendResolved = resolveBlendRaster(cs.blendRaster, ctx.caps());
  if (!blendResolved) return blendResolved.error();
  p.blend = hasBlend() ? *blendResolved : BlendRaster::Compute;
  // The hardware blend raster: mesh shaders where the device has them, unless indirect was asked for.
  p.meshBlend = ctx.caps().meshShader && p.backend != RasterBackend::Indirect;
  p.bufferTarget = p.backend == RasterBackend::Compute || p.backend == RasterBackend::Hybrid;
  p.lean = p.backend == RasterBackend::Compute && cs.leanRaster; // hybrid's down list is the hardware one
  if (cs.readVisibility && !p.bufferTarget)
    return Error{
        fmt::format("reading the visibility buffer needs --raster compute or hybrid, not {}", toString(p.backend))};
  p.readVisibility = cs.readVisibility;
  if (cs.surfels && !p.bufferTarget)
    return Error{fmt::format("mesh + surfel scenes share the 64-bit visibility buffer: --raster {} cannot draw "
                             "them (use compute or hybrid)",
                             toString(p.backend))};
  p.occlusion = cs.occlusionCulling && historyUsable;
  if (cs.readOwnedClusters && !p.occlusion)
    return Error{"reading the clusters that own pixels needs occlusion culling (its history)"};
  p.pvs = cs.pvsCulling && pvsInstances;
  p.transparency = hasBlend() && cs.transparency;
  // The blend queue serves the compute blend list (all of it, or hybrid's small-triangle clusters).
  p.blendQueue = p.transparency && blendQueueCapacity > 0 && p.blend != BlendRaster::Hardware &&
                 std::isfinite(cs.blendQueuePixels) && cs.blendQueueLimit > 0;
  p.particles = cs.particles && cs.particles->batchCount() != 0 && cs.debugView == DebugView::None;
  p.splat = p.particles && cs.particles->splats(OitMode::LinkedList);
  // Packed storage writes 64-bit keys by atomics; particle billboards append to linked lists.
  p.packed = p.transparency && (cs.oit == OitMode::Packed || cs.oit == OitMode::Fixed) && !p.particles &&
             ctx.caps().int64BufferAtomics;
  // Fixed slots: with the compute blend raster alone, whose second rasterization (and blend queue)
  // can stand idle when nothing is to be placed again (shaderio/oit.h, MIRAGE_OIT_FIXED_*).
  p.fixed = p.packed && cs.oit == OitMode::Fixed && p.blend == BlendRaster::Compute && oitPackedFrames == 0;
  if (cs.stereoIpd) { // docs/render.md, "Stereo": what the shared selection cannot serve yet
    if (Status st = validateIpd(*cs.stereoIpd); !st) return st.error();
    if (uint64_t(s.width) * 2 > kMaxRenderDimension)
      return Error{fmt::format("--stereo: the side-by-side target {}x{} exceeds {} pixels across", s.width * 2,
                               s.height, kMaxRenderDimension)};
    if (cs.readOwnedClusters) return Error{"--stereo cannot read the clusters owning pixels"};
    p.stereo = true;
  }
  // Stereo debug views resolve from the side-by-side visibility buffer of the buffer backends.
  if (cs.debugView != DebugView::None && p.stereo && !p.bufferTarget)
    return Error{fmt::format("--debug-view {} with --stereo needs --raster compute or hybrid, not {}",
                             toString(cs.debugView), toString(p.backend))};
  // The image backends count overdraw in their fragment shaders (a storage atomic).
  if (cs.debugView == DebugView::Overdraw && !p.bufferTarget && !ctx.caps().fragmentStoresAndAtomics)
    return Error{fmt::format("--debug-view overdraw: --raster {} needs stores and atomics in fragment shaders, which "
                             "the device lacks",
                             toString(p.backend))};
  p.debugView = cs.debugView;
  if (p.stereo) {
    auto mode = resolveStereoMode(cs.stereoMode, p, ctx.caps());
    if (!mode) return mode.error();
    p.multiview = *mode == StereoMode::Multiview;
  }
  p.surfels = cs.surfels;
  // With GPU residency too: every selection draws the resident cut (docs/render.md, "Residency").
  p.dagTree = cs.selection == SelectionMode::Dag;
  p.hierarchy = p.dagTree || cs.selection == SelectionMode::Hierarchy ||
                (cs.selection == SelectionMode::Auto && scene.instanceCount >= kHierarchyInstances);
  return p;
}

Status ClusterRenderer::Impl::packFrame(const ClusterRenderSettings& cs, const ClusterFramePlan& plan) {
  const RenderSettings& s = cs.base;
  Camera cam = withClipPlanes(s.camera, scene.worldBounds);
  sio::ClusterFrame f{};
  f.camera = viewFrame(cam, s.width, s.height);
  f.lightDir = glm::vec4(glm::normalize(s.lightDirection), s.lightIntensity);
  f.skyAmbient = glm::vec4(s.skyAmbient, 0.0f);
  f.groundAmbient = glm::vec4(s.groundAmbient, 0.0f);
  f.tau = cs.tauPixels;
  f.flags =
      (cs.flagBackFaces ? MIRAGE_FRAME_FLAG_BACKFACES : 0u) | (cs.frustumCulling ? MIRAGE_FRAME_FRUSTUM_CULL : 0u) |
      (plan.bufferTarget ? MIRAGE_FRAME_SOURCE_BUFFER : 0u) |
      (plan.backend == RasterBackend::Hybrid ? MIRAGE_FRAME_HYBRID : 0u) |
      (plan.occlusion ? MIRAGE_FRAME_OCCLUSION : 0u) | (cs.coneCulling ? MIRAGE_FRAME_CONE_CULL : 0u) |
      (plan.hierarchy ? MIRAGE_FRAME_HIERARCHY : 0u) | (plan.pvs ? MIRAGE_FRAME_PVS : 0u) |
      (plan.blend == BlendRaster::Hybrid ? MIRAGE_FRAME_BLEND_HYBRID : 0u) |
      (plan.blend == BlendRaster::Hardware ? MIRAGE_FRAME_BLEND_HARDWARE : 0u) | (plan.dagTree ? MIRAGE_FRAME_DAG : 0u);
  if (plan.clearsVisibility()) f.flags |= MIRAGE_FRAME_CLEAR_VIS;
  if (plan.lean) f.flags |= MIRAGE_FRAME_LEAN_RASTER;
  if (plan.packed) f.flags |= MIRAGE_FRAME_OIT_PACKED;
  if (residency) packResidency(f);
  if (cs.foveation) {
    // The gaze ray through the screen point (Vulkan NDC: y down; any depth between the planes).
    glm::vec4 p = f.camera.invViewProj * glm::vec4(2.0f * cs.foveaGaze - 1.0f, 0.5f, 1.0f);
    glm::vec3 gaze = glm::normalize(glm::vec3(p) / p.w - glm::vec3(f.camera.eye));
    float radius = glm::radians(cs.foveaRadiusDegrees);
    f.fovea = glm::vec4(gaze, radius);
    f.foveaSlope = sio::foveaSlope(radius);
    f.flags |= MIRAGE_FRAME_FOVEA;
  }
  f.debugView = uint32_t(plan.debugView); // DebugView's order is MIRAGE_DEBUG_VIEW_*'s
  if (plan.debugView == DebugView::Overdraw) {
    f.flags |= MIRAGE_FRAME_OVERDRAW;
    f.overdrawAddress = overdrawCounts.address();
  }
  if (plan.pvs) {
    f.pvsInstanceAddress = pvsInstances.address();
    f.pvsClusterAddress = pvsClusters.address();
  }
  f.visibleCapacity = visibleCapacity;
  f.instanceCount = scene.instanceCount;
  f.background = s.background;
  f.hybridThreshold = cs.hybridThreshold;
  f.hzbLevels = hzbLevels;
  f.historyAddress = history.address();
  f.candidateAddress = candidates.address();
  f.hzbAddress = hzb.address();
  f.lateInstanceAddress = lateInstances.address();
  f.instanceHistoryBase = uint32_t(scene.instancedClusters);
  std::copy(std::begin(hzbOffset), std::end(hzbOffset), std::begin(f.hzbOffset));
  // Stereo: the eyes sharing one projection, and the right eye's clip x shift (camera.h).
  std::array<Camera, 2> eyes{};
  float clipDx = 0.0f;
  if (plan.stereo) {
    eyes = stereoEyesSharedClip(s.camera, *cs.stereoIpd, scene.worldBounds);
    auto dx = stereoClipDx(viewFrame(eyes[0], s.width, s.height), *cs.stereoIpd);
    if (!dx) return dx.error();
    clipDx = *dx;
  }
  if (cs.surfels) {
    if (!fade) {
      fade = createBuffer(ctx, uint64_t(std::max(scene.instanceCount, 1u)) * 4,
                          VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::GpuOnly,
                          "mesh fade");
      surfelLink = createBuffer(ctx, sizeof(sio::ClusterSurfelLink), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                MemoryUsage::Upload, "surfel link");
    }
    SurfelStageFrame sf;
    sf.camera = f.camera;
    sf.visBufferAddress = visBuffer.address();
    sf.meshFadeAddress = fade.address();
    sf.slot = currentSlot;
    if (plan.stereo) { // one prefix selection from the nearer eye, splatted into both halves
      sf.camera = viewFrame(eyes[0], s.width, s.height);
      sf.eyes = 2;
      sf.stereoEye = glm::vec4(eyes[1].eye - eyes[0].eye, clipDx);
    }
    SurfelRenderSettings ss = cs.surfelSettings;
    ss.meshFade = true;
    ss.frustumCulling = cs.frustumCulling;
    if (Status st = cs.surfels->stagePrepare(ss, sf); !st) return st.error();
    sio::ClusterSurfelLink link = cs.surfels->stageLink();
    // One link buffer for every slot: written only when it changes (another surfel renderer), so
    // frames in flight never read it while the host writes it.
    if (std::memcmp(surfelLink.mapped(), &link, sizeof(link)) != 0) {
      if (std::any_of(std::begin(recorded), std::end(recorded), [](bool r) { return r; }))
        vkDeviceWaitIdle(ctx.device()); // rare: the renderer is switched while frames run
      std::memcpy(surfelLink.mapped(), &link, sizeof(link));
    }
    f.fadeAddress = fade.address();
    f.surfelLinkAddress = surfelLink.address();
  }
  f.lightAddress = scene.lights.address();
  f.lightCount = scene.lightCount;
  f.nodeAddress = scene.lodNodes.address();
  f.leafClusterAddress = scene.leafClusters.address();
  f.traversalAddress = traversal.address();
  f.queueAddress[0] = queues[0].address();
  f.queueAddress[1] = queues[1].address();
  f.queueCapacity = queueCapacity;
  if (oitHeads) { // BLEND materials or particles
    f.blendVisibleAddress = blendVisible.address();
    f.oitHeadAddress = oitHeads.address();
    f.oitNodeAddress = oitNodes.address();
    f.blendCapacity = blendCapacity;
    f.oitNodeCapacity = oitNodeCapacity;
    f.oitFixedSlots = plan.oitFixedSlots;
    f.oitFixedStride = colorWidth * height;
    f.oitCounterAddress = counters.address() + offsetof(sio::ClusterCounters, oit);
    f.oitColorAddress = oitColors ? oitColors.address() : oitNodes.address(); // see ClusterFrame
  }
  if (plan.particles) { // the billboards' view of the same lists, their ids tagged as stored colours
    sio::OitLists l{
        oitHeads.address(), oitNodes.address(),     oitColors.address(), f.oitCounterAddress, colorWidth, height,
        oitNodeCapacity,    MIRAGE_OIT_COLOR_ID_TAG};
    std::memcpy(particleLists[currentSlot].mapped(), &l, sizeof(l));
  }
  if (plan.blendQueue) {
    f.blendQueueAddress = blendQueue.address();
    f.blendQueueCapacity = std::min(blendQueueCapacity, cs.blendQueueLimit);
    f.blendQueuePixels = cs.blendQueuePixels;
  }
  std::memcpy(frames[currentSlot].mapped(), &f, sizeof(f));
  if (plan.stereo) {
    // The selection frame sees the camera plus half the IPD on each side; each eye frame is the
    // frame of that eye writing its half. The eyes share one projection (the union of their clip
    // ranges), so a world point's clip positions differ by the projection's x column times the
    // view-space offset between the eyes, (-ipd, 0, 0): clip x by -ipd * P00, and y, z, w not at
    // all (P10 = P20 = P30 = 0 for every Camera::projection). The compute raster relies on it.
    f.stereoHalf = glm::vec4(0.5f * (eyes[1].eye - eyes[0].eye), 0.0f);
    f.flags |= MIRAGE_FRAME_STEREO; // its HZB tests look through both eye frames (hzbVisible)
    std::memcpy(frames[currentSlot].mapped(), &f, sizeof(f));
    for (uint32_t e = 0; e < 2; ++e) {
      sio::ClusterFrame ef = f;
      ef.stereoHalf = glm::vec4(0.0f);
      ef.camera = viewFrame(eyes[e], s.width, s.height);
      ef.targetOffsetX = e * s.width;
      ef.flags |= MIRAGE_FRAME_STEREO;
      ef.stereoClipDx = clipDx;
      std::memcpy(frames[currentSlot].mapped() + (e + 1) * kFrameStride, &ef, sizeof(ef));
    }
  }
  return Ok{};
}

// The slot's counters as cmdFrame copied them at the end of its frame.
ClusterStats ClusterRenderer::Impl::readStats(uint32_t frameSlot) const {
  const ClusterFramePlan& plan = plans[frameSlot];
  const uint8_t* raw = readbacks[frameSlot].mapped();
  sio::ClusterCounters c{};
  std::memcpy(&c, raw, sizeof(c));
  ClusterStats st;
  if (plan.hierarchy) {
    sio::ClusterTraversal t{};
    std::memcpy(&t, raw + sizeof(c), sizeof(t));
    st.nodesTested = t.nodesTested;
    st.selectionPasses = (plan.dagTree ? scene.dagDepth : scene.lodDepth) + 1;
  }
  st.selection = plan.dagTree ? SelectionMode::Dag : plan.hierarchy ? SelectionMode::Hierarchy : SelectionMode::Flat;
  st.instancesVisible = c.visibleInstances;
  st.clustersTested = c.clustersTested;
  st.selectRows = c.selectArgs[1];
  st.clustersSelected = c.clustersSelected;
  st.clustersFrustumCulled = c.clustersFrustumCulled;
  st.clustersBackfaceCulled = c.clustersBackfaceCulled;
  st.clustersPass1 = c.clustersPass1;
  st.clustersOcclusionTested = std::min(c.candidates, visibleCapacity);
  st.clustersOcclusionCulled = c.clustersOcclusionCulled;
  st.instancesLate = c.lateInstances;
  st.instancesOcclusionCulled = c.instancesOcclusionCulled;
  st.historyKept = c.historyKept;
  st.clustersDrawn = c.listEnd[0] + c.listEnd[1] + std::min(c.blendClusters, blendCapacity);
  st.clustersBlend = std::min(c.blendClusters, blendCapacity);
  st.clustersBlendHardware = c.blendListEnd[MIRAGE_LIST_DOWN];
  st.blendRaster = plan.blend;
  st.blendQueueTriangles = uint32_t(c.blendQueueCounts >> 32);
  st.blendQueueTiles = uint32_t(c.blendQueueCounts);
  st.blendQueueOverflow = c.blendQueueOverflow;
  OitStats oit = oitStats(c.oit, oitNodeCapacity);
  st.oitFragments = oit.fragments;
  st.oitPoolOverflow = oit.poolOverflow;
  st.oitLayersDropped = oit.capDropped + oit.layersDropped;
  st.msl = oit.msl;
  st.oitFixedSlots = plan.oitFixedSlots;
  st.oitFixedRedone = (c.oit.fixedState & MIRAGE_OIT_FIXED_OVER) != 0;
  st.clustersHardware = c.clustersHardware;
  st.clustersLean = plan.lean ? c.listEnd[MIRAGE_LIST_DOWN] : 0; // the compute backend's down list is the lean one
  st.trianglesNearClipped = c.trianglesNearClipped;
  st.clustersOverflow = c.clustersOverflow;
  st.trianglesRasterized = c.trianglesSelected;
  st.instancesPvsCulled = c.instancesPvsCulled;
  st.clustersPvsCulled = c.clustersPvsCulled;
  st.pvs = plan.pvs;
  st.raster = plan.backend;
  st.stereoMode = !plan.stereo ? StereoMode::Auto : plan.multiview ? StereoMode::Multiview : StereoMode::Viewports;
  st.occlusion = plan.occlusion;
  return st;
}

} // namespace mirage::render
