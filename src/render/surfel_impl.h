#pragma once
// Private state of SurfelRenderer, shared by its source files:
//   surfel_renderer.cpp  names, the coherent order, upload, pipelines, per-size targets
//   surfel_frame.cpp     settings -> frame plan and SurfelRenderFrame, the per-frame commands,
//                        render / record / collect, and the mixed-scene stage
#include <vector>

#include "mirage/gpu/deletion_queue.h"
#include "mirage/gpu/descriptors.h"
#include "mirage/gpu/memory.h"
#include "mirage/gpu/pipeline.h"
#include "mirage/gpu/query.h"
#include "mirage/render/surfel_renderer.h"
#include "mirage/shaderio/surfel_render.h"

namespace mirage::render {

constexpr VkFormat kSurfelColorFormat = VK_FORMAT_R16G16B16A16_SFLOAT; // as the mesh renderers
constexpr VkFormat kSurfelVisFormat = VK_FORMAT_R32G32_UINT;           // (id, 0), as the cluster renderer
constexpr VkFormat kSurfelDepthFormat = VK_FORMAT_D32_SFLOAT;
constexpr VkShaderStageFlags kSurfelPushStages =
    VK_SHADER_STAGE_COMPUTE_BIT | VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;

// What one frame runs: the settings resolved against the device.
struct SurfelFramePlan {
  SurfelRaster raster = SurfelRaster::Compute; // never Auto once planned
  bool cullBackFaces = false;                  // which splat pipeline runs
  bool subgroupMerge = false;
  uint32_t eyes = 1; // 2: stereo, both eyes side by side
};

struct SurfelRenderer::Impl {
  gpu::Context& ctx;
  gpu::Buffer positions, attributes, radii, clouds, instances, materials; // set-up time
  gpu::Buffer mapTransforms;                                              // the materials' (uploadMaterials)
  gpu::Buffer lights;                                                     // GpuPointLight[lightCount]
  std::vector<uint32_t> resolveSpecialization; // shading.glsl's kMaterialMaps (materialMapSpecialization)
  uint32_t lightCount = 0;
  // GPU-only scratch every frame slot shares (each frame's first barrier orders it after the
  // frames submitted before it).
  gpu::Buffer states, counters, draws, visBuffer, batchInstance;
  std::vector<gpu::Image> textures; // one white texel: shading.glsl's array
  gpu::Unique<VkSampler> sampler, nearestSampler;
  gpu::Unique<VkPipelineLayout> layout;
  gpu::Unique<VkPipeline> prefixPipeline, scanPipeline, rasterPipeline, resolvePipeline;
  // [merge pipeline (per-instance choice)][back-face culling][stereo]; stereo ones on first use.
  gpu::Unique<VkPipeline> splatPipelines[2][2][2];
  gpu::Image color, vis, depth;
  uint32_t width = 0, height = 0, colorWidth = 0, instanceCount = 0; // colorWidth: 2 * width in stereo
  uint64_t surfelCount = 0, instancedCount = 0;
  uint64_t maxBatches = 0; // splat batches when every instance draws all its surfels
  Bounds worldBounds;
  SurfelOrder order = kDefaultSurfelOrder;

  // Frames in flight: what the CPU writes or reads while other frames run is per slot.
  gpu::Buffer frames[kMaxFramesInFlight];             // SurfelRenderFrame, written at record time
  gpu::Buffer readbacks[kMaxFramesInFlight];          // SurfelRenderCounters, copied at the frame's end
  gpu::DescriptorSet descriptors[kMaxFramesInFlight]; // the slot's targets (rewritten at record time)
  std::vector<gpu::GpuTimer> timers;
  SurfelFramePlan plans[kMaxFramesInFlight];
  shaderio::SurfelRenderPush stagePush[kMaxFramesInFlight] =
      {}; // mixed scenes: the shared visibility buffer and fade array
  bool recorded[kMaxFramesInFlight] = {};
  gpu::DeletionQueue retired; // targets replaced while recorded, uncollected slots may still use them
  uint32_t currentSlot = 0;   // the slot being recorded

  explicit Impl(gpu::Context& c) : ctx(c) {
    for (uint32_t i = 0; i < kMaxFramesInFlight; ++i) timers.emplace_back(c);
  }
  gpu::GpuTimer& timer() { return timers[currentSlot]; }
  uint32_t inFlightSlots() const; // bit i: slot i recorded and not yet collected

  // surfel_renderer.cpp
  Status upload(const SurfelScene& scene);
  void createPipelines();
  VkPipeline splatPipeline(const SurfelFramePlan& plan);
  void ensureTargets(uint32_t w, uint32_t h, uint32_t colorW);
  void writeDescriptors(uint32_t slot);
  shaderio::SurfelRenderPush push() const;

  // surfel_frame.cpp
  Result<SurfelFramePlan> plan(const SurfelRenderSettings& settings) const;
  Status prepareFrame(const SurfelRenderSettings& settings, uint32_t slot);
  void cmdFrame(VkCommandBuffer cmd);
  void cmdPrefix(VkCommandBuffer cmd, const shaderio::SurfelRenderPush& p, gpu::GpuTimer& t);
  void cmdSplat(VkCommandBuffer cmd, const SurfelFramePlan& plan, gpu::GpuTimer& t); // push constants from cmdPrefix
  void cmdResolve(VkCommandBuffer cmd, const shaderio::SurfelRenderPush& p);
  void cmdCountersToReadback(VkCommandBuffer cmd);
  SurfelRenderOutput readCounters(uint32_t slot) const;
};

} // namespace mirage::render
