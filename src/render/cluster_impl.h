#pragma once
// Private state of ClusterRenderer, shared by its source files (docs/render.md, "Files"):
//   cluster_upload.cpp     scene data, set-up time
//   cluster_lod_tree.cpp   the LOD BVH and DAG group tree (cluster_lod_tree.h), grown as pages arrive
//   cluster_pipelines.cpp  pipelines, descriptors, per-size targets and per-scene buffers
//   cluster_frame.cpp      settings -> frame plan, ClusterFrame packing, counters -> stats
//   cluster_select.cpp     selection: instance cull, flat pass, LOD BVH / DAG traversal, raster args
//   cluster_raster.cpp     visibility rasterizers and the resolve (both stereo eyes in one pass)
//   cluster_occlusion.cpp  HZB build and the pass-2 occlusion cull (history)
//   cluster_oit.cpp        alpha BLEND: blend rasters and the sorted composite
//   cluster_particles.cpp  particle billboards into the transparency lists
//   cluster_residency.cpp  GPU residency of paged DAGs: page pool, uploads, feedback (cluster_residency.h)
//   cluster_renderer.cpp   the public API and the per-frame phase list
#include <memory>
#include <span>
#include <vector>

#include "mirage/gpu/deletion_queue.h"
#include "mirage/gpu/descriptors.h"
#include "mirage/gpu/memory.h"
#include "mirage/gpu/pipeline.h"
#include "mirage/gpu/query.h"
#include "mirage/render/cluster_renderer.h"
#include "mirage/render/particle_draw.h"
#include "mirage/shaderio/cluster.h"
#include "render_util.h"

namespace mirage::render {

// Everything uploaded once per asset (docs/render.md, "Data layout").

struct ClusterSceneData {
  gpu::Buffer clusters;                        // GpuCluster[], all meshes' DAGs concatenated (none with residency)
  gpu::Buffer vertices;                        // GpuClusterVertex[], all attribute vertices
  gpu::Buffer clusterVertices;                 // uint[], attribute-vertex ids rebased to `vertices`
  gpu::Buffer indices;                         // uint[], local 8-bit indices packed 4 per word
  gpu::Buffer meshes;                          // GpuClusterMesh[]
  gpu::Buffer levels;                          // GpuClusterLevel[], per mesh (GpuClusterMesh::levelOffset)
  gpu::Buffer instances;                       // GpuClusterInstance[]
  gpu::Buffer materials;                       // GpuMaterial[] (the forward renderer's layout)
  gpu::Buffer mapTransforms;                   // the materials' map transforms (uploadMaterials)
  gpu::Buffer lodNodes;                        // GpuLodNode[], per mesh (GpuClusterMesh::nodeOffset)
  gpu::Buffer leafClusters;                    // uint[]: mesh-local cluster ids of the LOD BVH's leaves
  gpu::Buffer lights;                          // GpuPointLight[lightCount] (one unused entry without lights)
  std::vector<uint32_t> resolveSpecialization; // shading.glsl's kMaterialMaps (materialMapSpecialization)
  std::vector<gpu::Image> textures;
  gpu::Unique<VkSampler> sampler;        // trilinear, repeat: material textures
  gpu::Unique<VkSampler> nearestSampler; // the integer visibility image
  uint32_t clusterCount = 0;
  uint32_t instanceCount = 0;
  uint32_t lightCount = 0;
  uint32_t maxMeshClusters = 0;
  uint32_t maxMeshNodes = 0;              // largest LOD BVH of one mesh (nodes)
  uint32_t lodDepth = 0;                  // deepest LOD BVH node below its level root (traversal passes - 1)
  uint32_t dagDepth = 0;                  // deepest node of the DAG group trees (--selection dag: passes - 1)
  uint64_t instancedClusters = 0;         // sum over instances of their mesh's clusters (history bits)
  uint64_t blendInstancedClusters = 0;    // the same over BLEND instances: 0 = no transparency passes
  bool hasMask = false;                   // a MASK instance: the compute raster adds the masked kernel
  std::vector<uint32_t> instanceClusters; // per GPU instance: its mesh's cluster count (history ranges)
  Bounds worldBounds;
};

// Uploads `asset`; errors for clusters beyond the mesh-shader limits or an empty scene.
Result<ClusterSceneData> uploadClusterScene(gpu::Context& ctx, const lod::LodAsset& asset);
// The per-scene part of both uploads: the mesh table (`meshes`, one per scene mesh, object-space
// `meshBounds`), instances, materials, textures, lights and samplers. Errors: no instances.
Status uploadClusterInstances(gpu::Context& ctx, const Scene& scene, std::vector<shaderio::GpuClusterMesh> meshes,
                              const std::vector<Bounds>& meshBounds, ClusterSceneData& d);
// One cluster's record (offsets as the cluster has them: the caller rebases them) and normal cone
// (meshoptimizer; cutoff 1, never culled, for degenerate clusters) from its vertex positions in
// its own order and its 8-bit local indices, and its longest triangle edge (GpuCluster::maxEdge,
// rounded up) from the same. Written once for both uploads and the page pool.
shaderio::GpuCluster clusterRecord(const lod::Cluster& c, uint32_t mesh);
shaderio::GpuClusterCone clusterCone(std::span<const glm::vec3> positions, std::span<const uint8_t> localIndices);
float clusterMaxEdge(std::span<const glm::vec3> positions, std::span<const uint8_t> localIndices);

// A GpuClusterInstance's flags from its material and transform: double-sided, mirrored (negative
// determinant: the winding flips) and the alpha mode (the rasterizers branch on them per cluster,
// so opaque clusters never touch the alpha code; docs/render.md, "Alpha").
uint32_t clusterInstanceFlags(const Material& material, const glm::mat4& model);

// Threads per eye of the compute rasterizers (cluster_raster.glsl's specialization): 128, one round
// over a cluster's triangles (measured on an H100 against 32, 64 and 256: 64 threads took 79
// registers, 128 take 64, so more warps hide the walks' latency). Stereo uses twice as many.
constexpr uint32_t kClusterRasterLanes = 128;

struct ClusterResidency; // cluster_residency.h

constexpr VkFormat kColorFormat = VK_FORMAT_R16G16B16A16_SFLOAT; // as the forward renderer
constexpr VkFormat kVisFormat = VK_FORMAT_R32G32_UINT;           // (visible index + 1, triangle)
constexpr VkFormat kDepthFormat = VK_FORMAT_D32_SFLOAT;
// Visible-cluster entries: the instanced cluster count, capped so the buffer stays 32 MiB.
constexpr uint64_t kMaxVisibleClusters = 4u << 20;
// Blend queue entries (48 bytes each): 4 per triangle of the blend clusters (a near-clipped
// triangle draws as two, stereo draws each eye's), capped at 12 MiB; more large triangles in one
// frame are walked by their cluster's workgroup (counted).
constexpr uint64_t kMaxBlendQueueTriangles = 1u << 18;
// Transparency node pool when ClusterRenderSettings::oitNodesPerPixel is 0: this many blended
// fragments per pixel on average (12 bytes each), capped by the device's storage-buffer range.
constexpr uint32_t kOitNodesPerPixel = 4;
// With particle billboards in the lists: as many as the forward renderer's default pool (its
// particles and the cluster renderer's then fill the same pool).
constexpr uint32_t kOitNodesPerPixelParticles = 8;
// Frames stored as Packed after one whose pixels outnumbered their fixed slots (oitPackedFrames):
// a scene deeper than the pool's slots pays the wasted stores once in this many frames.
constexpr uint32_t kOitPackedFramesAfterOverflow = 30;

// Every pass reaches its buffers through device addresses, which synchronization validation does
// not track, so each phase boundary is one conservative global barrier: whatever compute, fragment
// or transfer work wrote is visible to every later indirect read, shader access and transfer.
void cmdPhaseBarrier(VkCommandBuffer cmd, bool meshShaders);

// Byte offsets of one raster pass's indirect arguments in ClusterCounters.
inline VkDeviceSize listArgsOffset(uint32_t pass, uint32_t list) {
  return offsetof(shaderio::ClusterCounters, lists) + (pass * 2 + list) * sizeof(shaderio::ClusterListArgs);
}
inline VkDeviceSize dispatchArgsOffset(uint32_t pass, uint32_t list) {
  return listArgsOffset(pass, list) + offsetof(shaderio::ClusterListArgs, dispatch);
}
inline VkDeviceSize drawArgsOffset(uint32_t pass, uint32_t list) {
  return listArgsOffset(pass, list) + offsetof(shaderio::ClusterListArgs, draw);
}

// What one frame runs: the settings resolved against the device and the scene.
struct ClusterFramePlan {
  RasterBackend backend = RasterBackend::Auto; // never Auto once planned
  BlendRaster blend = BlendRaster::Compute;    // Compute for scenes without BLEND materials
  bool meshBlend = false;                      // the hardware blend raster uses mesh shaders (else indirect draws)
  bool bufferTarget = false;                   // visibility in the 64-bit buffer (compute, hybrid), else the image
  bool lean = false;         // compute: the lean raster draws the down list (MIRAGE_FRAME_LEAN_RASTER)
  bool occlusion = false;    // two-pass HZB occlusion culling runs
  bool pvs = false;          // the cell's cluster PVS culls
  bool dagTree = false;      // hierarchical selection over the DAG's group tree
  bool hierarchy = false;    // hierarchical selection (LOD BVH or DAG tree), else the flat pass
  bool stereo = false;       // two eyes side by side (ClusterRenderSettings::stereoIpd)
  bool multiview = false;    // stereo: the hardware rasters draw both eyes by multiview (docs/render.md, "Stereo")
  bool transparency = false; // BLEND clusters rasterized and composited (scene has them, asked for)
  // The resolve leaves the 64-bit buffer zeroed (MIRAGE_FRAME_CLEAR_VIS): it is the buffer's last
  // reader of the frame (the blend rasters' and particles' depth copy reads it).
  bool clearsVisibility() const {
    return bufferTarget && debugView == DebugView::None && !transparency && !particles && !readVisibility;
  }
  bool readVisibility = false; // the buffer is read back after the frame (ClusterRenderSettings::readVisibility)
  bool blendQueue = false;     // the compute blend raster queues large triangles (cluster_blend_queue.comp)
  bool particles = false;      // particle billboards into the transparency lists (cluster_particles.cpp)
  bool splat = false;          // small particles splatted (ParticleDraw::splats)
  bool packed = false;         // transparency in packed storage (MIRAGE_FRAME_OIT_PACKED)
  bool fixed = false;          // packed storage in fixed slots (--oit fixed, the compute blend raster)
  uint32_t oitFixedSlots = 0;  // fixed: the slots per pixel (set once the pool is made: fixedSlotsFor)
  DebugView debugView = DebugView::None; // the debug resolve runs instead of the shading one
  SurfelRenderer* surfels = nullptr;     // mixed frames: the surfel stage (its counters in its slot's readback)
};

// Frames per slot in the frame buffer: the selection frame, then stereo's left and right eye frames.
inline constexpr uint32_t kFramesPerSlot = 3;
// Byte stride of those frames (a multiple of every member's alignment).
inline constexpr VkDeviceSize kFrameStride = MIRAGE_CLUSTER_FRAME_STRIDE;

struct ClusterRenderer::Impl {
  gpu::Context& ctx;
  ClusterSceneData scene;
  gpu::Buffer visibleInstances, lateInstances, visible, counters, visBuffer, candidates, history, hzb;
  gpu::Buffer fade, surfelLink;     // mixed scenes: per-instance fade, ClusterSurfelLink (created on first use)
  gpu::Buffer traversal, queues[2]; // hierarchical selection: counters / indirect arguments, node queues
  gpu::Buffer blendVisible, oitHeads, oitNodes; // alpha BLEND: own cluster list, per-pixel fragment lists
  gpu::Buffer blendQueue;                       // alpha BLEND: BlendQueueTriangle[blendQueueCapacity]
  // The node pool is not all zero (new, or packed frames wrote keys): the next linked-list frame
  // zeroes it (the lists' overflow rule tells unwritten nodes by 0; packed frames need no zeros).
  bool oitNodesUnzeroed = false;
  // Packed storage's ranges pass (oit_ranges.comp, its own push constants): per-block histograms
  // and first slots (OitRangesScratch), sized with the heads.
  gpu::Buffer oitRangesScratch;
  gpu::Unique<VkPipelineLayout> oitRangesLayout;
  gpu::Unique<VkPipeline> oitRangesPipeline;
  // Particles (cluster_particles.cpp), made on the first frame with them: the colour beside each
  // node of the lists (which then exist without BLEND materials too), and per slot the OitLists the
  // billboards append through.
  gpu::Buffer oitColors, particleLists[kMaxFramesInFlight];
  gpu::Buffer splatAccum;   // the particle splat's sums (ParticleDraw::splatBytes), made on first use
  bool particleOit = false; // the lists carry particles from now on (their pool sized for them)
  // Per slot (identically defined layouts are compatible): material textures, and the slot's
  // frame's visibility image, colour target and depth, written when the slot is recorded while
  // other slots' frames may still read their own (a resize mid-flight).
  gpu::DescriptorSet descriptors[kMaxFramesInFlight];
  gpu::Buffer pvsInstances, pvsClusters; // the camera cell's cluster PVS (setPvs); empty: no PVS culling
  // A new cell's PVS waiting in host memory (instance offsets, then cluster bits): the next frame
  // recorded copies it into pvsInstances / pvsClusters before its first barrier, so a cell change
  // never waits for the GPU.
  gpu::Buffer pvsStaging;
  gpu::Unique<VkPipelineLayout> layout;
  gpu::Unique<VkPipeline> cullPipeline, selectPipeline, traversePipeline, argsPipeline, rasterPipeline,
      rasterMaskPipeline, meshPipeline, indirectPipeline, meshAtomicPipeline, indirectAtomicPipeline, occlusionPipeline,
      instanceOcclusionPipeline, hzbPipeline, resolvePipeline, blendRasterPipeline, blendQueuePipeline,
      compositePipeline, compositeStoredPipeline; // the latter: created on first use
  gpu::Unique<VkPipeline> rasterStereoPipeline, rasterMaskStereoPipeline, blendRasterStereoPipeline; // both eyes
  gpu::Unique<VkPipeline> rasterLeanPipeline, rasterLeanStereoPipeline; // cluster_raster_lean.comp, mono / stereo
  // Hardware blend raster, created on first use: mesh / indirect, and the buffer backends' depth copy.
  gpu::Unique<VkPipeline> blendMeshPipeline, blendIndirectPipeline, blendDepthPipeline;
  // Debug views, created on first use: the debug resolve, the image backends' overdraw-counting
  // visibility rasters, and the overdraw view's per-pixel counts (recreated with the targets).
  gpu::Unique<VkPipeline> debugResolvePipeline, overdrawMeshPipeline, overdrawIndirectPipeline;
  gpu::Buffer overdrawCounts;
  // Stereo by multiview (docs/render.md, "Stereo"), created on first use: the visibility rasters
  // with view mask 0b11 ([mesh][atomic]), and the image backends' 2-layer targets (one eye a layer)
  // that each pass copies into the side-by-side visibility image and depth.
  gpu::Unique<VkPipeline> multiviewPipelines[2][2];
  gpu::Image layeredVis, layeredDepth;
  VkShaderStageFlags pushStages = 0;
  gpu::Image color, vis, depth;
  uint32_t colorWidth = 0; // the colour target: width, or 2 * width in stereo (left|right)
  uint32_t width = 0, height = 0, visibleCapacity = 0, hzbLevels = 0, queueCapacity = 0;
  uint32_t blendCapacity = 0, oitNodeCapacity = 0; // 0 without BLEND materials: no transparency passes
  // Fixed slots that a frame's pixels outnumbered leave that frame's first rasterization's stores
  // wasted: the next this-many frames store as Packed (the same image) and then try again; a new
  // pool, size, eye count or blend queue setting tries at once (oitFixedKey).
  uint32_t oitPackedFrames = 0;
  uint64_t oitFixedKey = 0;
  uint32_t blendQueueCapacity = 0; // entries of blendQueue (0: no queue on this device)
  uint32_t oitNodesPerPixel = 0;   // the pool's size (ensureOitPool)
  uint32_t traversalDepth = 0;     // deepest node of the tree this frame traverses (LOD BVH or DAG group tree)
  uint32_t hzbOffset[MIRAGE_HZB_MAX_LEVELS] = {};
  bool historyUsable = false; // the history bitmask fits (instance offsets below 2^32, buffer range)
  // vis and depth were transitioned out of UNDEFINED since they were made: every frame leaves them
  // in their read-only layouts, so the buffer backends (which never write them) transition them
  // once, not per frame.
  bool visImagesDefined = false;
  // visBuffer is all zero when the next recorded frame starts (the last recorded frame's resolve
  // cleared it), so that frame skips the fill. Frames run in the order they were recorded.
  bool visBufferZero = false;
  // Frames in flight (record/collect): what the CPU writes or reads while other frames run is per
  // slot; everything else is GPU-only scratch shared by the slots (see cmdFrame).
  gpu::Buffer frames[kMaxFramesInFlight];    // ClusterFrame, written by the CPU at record time
  gpu::Buffer readbacks[kMaxFramesInFlight]; // ClusterCounters + ClusterTraversal, copied at the frame's end
  std::vector<gpu::GpuTimer> timers;         // per slot: pass timestamps
  ClusterFramePlan plans[kMaxFramesInFlight];
  bool recorded[kMaxFramesInFlight] = {};
  gpu::DeletionQueue retired; // replaced PVS buffers and targets that recorded, uncollected slots may still use
  uint32_t currentSlot = 0;   // the slot being recorded
  std::unique_ptr<ClusterResidency> residency; // GPU residency of paged DAGs (null: every DAG uploaded whole)

  Impl(gpu::Context& c, ClusterSceneData s);
  ~Impl();
  gpu::GpuTimer& timer() { return timers[currentSlot]; }
  void createDescriptors(); // cluster_pipelines.cpp
  void createPipelines();
  gpu::Unique<VkPipeline> createVisPipeline(bool mesh, bool atomic, bool overdraw = false, bool multiview = false);
  uint32_t inFlightSlots() const; // slots recorded and not yet collected, as a bit mask
  void ensureTargets(uint32_t w, uint32_t h, uint32_t colorW);
  void createOitHeads();
  void ensureOitPool(uint32_t nodesPerPixel);
  // Fixed slots per pixel of a frame in fixed slots (plan.fixed): the pool's keys per target pixel,
  // at most MIRAGE_OIT_MAX_LAYERS; 0 otherwise (counted ranges or lists). cluster_oit.cpp.
  uint32_t fixedSlotsFor(const ClusterFramePlan& plan) const;
  void writeTargetDescriptors(uint32_t slot);
  void ensureMultiview(const ClusterFramePlan& plan);
  shaderio::ClusterPush push() const;
  void cmdPush(VkCommandBuffer cmd, shaderio::ClusterPush p, uint32_t rasterList);
  void cmdSelect(VkCommandBuffer cmd, const shaderio::ClusterPush& p, bool hierarchy);
  void cmdTraverse(VkCommandBuffer cmd, const shaderio::ClusterPush& p, uint32_t phase);
  void cmdArgs(VkCommandBuffer cmd, const shaderio::ClusterPush& p, uint32_t pass);
  void cmdRasterize(VkCommandBuffer cmd, const shaderio::ClusterPush& p, RasterBackend backend, uint32_t pass);
  void cmdHardwareList(VkCommandBuffer cmd, const shaderio::ClusterPush& p, RasterBackend backend, uint32_t pass,
                       bool atomic);
  void cmdMultiviewList(VkCommandBuffer cmd, const shaderio::ClusterPush& p, RasterBackend backend, uint32_t pass);
  void cmdBuildHzb(VkCommandBuffer cmd, const shaderio::ClusterPush& p);
  void cmdOcclusion(VkCommandBuffer cmd, const shaderio::ClusterPush& p, bool hierarchy);
  void cmdResolve(VkCommandBuffer cmd, const shaderio::ClusterPush& p);
  void cmdTransparency(VkCommandBuffer cmd, shaderio::ClusterPush p, const ClusterFramePlan& plan, bool blend,
                       ParticleDraw* particles);
  void cmdBlendDepth(VkCommandBuffer cmd, const shaderio::ClusterPush& p, bool bufferTarget, bool always);
  void cmdComputeBlend(VkCommandBuffer cmd, const shaderio::ClusterPush& p, bool queue, bool timed);
  void cmdBlendRasters(VkCommandBuffer cmd, const shaderio::ClusterPush& p, const ClusterFramePlan& plan, bool timed);
  void cmdOitRanges(VkCommandBuffer cmd, const ClusterFramePlan& plan);
  void prepareParticles(ParticleDraw& particles); // cluster_particles.cpp
  void cmdParticles(VkCommandBuffer cmd, const shaderio::ClusterPush& p, ParticleDraw& particles);
  ParticleSplatTarget splatTarget(const shaderio::ClusterPush& p);
  void cmdSplatResolve(VkCommandBuffer cmd, const shaderio::ClusterPush& p, ParticleDraw& particles);
  void cmdBeginFullTarget(VkCommandBuffer cmd, VkRenderingInfo ri, bool multiview = false);
  void cmdBeginOverOpaqueDepth(VkCommandBuffer cmd); // cluster_oit.cpp
  void cmdDrawList(VkCommandBuffer cmd, bool mesh, uint32_t pass, uint32_t list);
  void cmdDrawEyes(VkCommandBuffer cmd, const shaderio::ClusterPush& p, bool mesh, uint32_t pass, uint32_t list,
                   uint32_t rasterList);
  void cmdHardwareBlend(VkCommandBuffer cmd, const shaderio::ClusterPush& p, bool mesh);
  VkPipeline blendHardwarePipeline(bool mesh);
  // cluster_oit_composite.comp specialized by the scene's maps; `stored`: for
  // frames whose fragments all carry stored colours (MIRAGE_OIT_COMPOSITE_STORED), made on first use.
  VkPipeline createCompositePipeline(bool stored = false);
  bool hasBlend() const { return blendCapacity > 0; }
  // Hybrid's hardware list through mesh shaders (else indirect draws): where the device has them,
  // and with multiview stereo only where they have multiview (cluster_frame.cpp, resolveStereoMode).
  bool hybridListMesh() const {
    return meshAtomicPipeline && (!plans[currentSlot].multiview || ctx.caps().multiviewMeshShader);
  }

  // cluster_frame.cpp: settings resolved into a plan, the plan and camera packed into `frame`, the
  // counters read back into stats.
  Result<ClusterFramePlan> plan(const ClusterRenderSettings& cs) const;
  Status packFrame(const ClusterRenderSettings& cs, const ClusterFramePlan& plan);
  ClusterStats readStats(uint32_t slot) const;

  // cluster_renderer.cpp: plan, targets and frame data of `slot` (no commands), then its commands.
  Status prepareFrame(const ClusterRenderSettings& cs, uint32_t slot);
  void cmdFrame(VkCommandBuffer cmd, const ClusterRenderSettings& cs);
  void finishFrame(VkCommandBuffer cmd, const ClusterFramePlan& plan, uint32_t frameTime);

  // cluster_residency.cpp: the manager's step and the uploads staged (prepareFrame), recorded after
  // the frame's first barrier, the feedback copied out in finishFrame and read back by collect.
  Status prepareResidency(const ClusterRenderSettings& cs);
  void cmdResidencyUpload(VkCommandBuffer cmd);
  void cmdResidencyFeedback(VkCommandBuffer cmd);
  void packResidency(shaderio::ClusterFrame& f) const;
  ResidencyStats collectResidency(uint32_t slot);
};

} // namespace mirage::render
