#pragma once
// AtlasClientRenderer's state, shared by its files:
//   atlas_client.cpp        creation, patch slots, atlas uploads (the CPU side of the next frame)
//   atlas_client_frame.cpp  the frame: uploads recorded, opaque pass, linked-list transparency (BLEND
//                           patches and particles)
#include <unordered_map>
#include <vector>

#include "mirage/core/scene.h"
#include "mirage/gpu/deletion_queue.h"
#include "mirage/gpu/descriptors.h"
#include "mirage/gpu/pipeline.h"
#include "mirage/gpu/query.h"
#include "mirage/render/atlas_client.h"
#include "mirage/shaderio/atlas_client.h"
#include "mirage/shaderio/forward.h" // MIRAGE_ALPHA_*, ForwardResolvePush (the forward resolve is reused)
#include "mirage/shaderio/oit.h"

namespace mirage::render {

constexpr VkFormat kAtlasFormat = VK_FORMAT_R8G8B8A8_SRGB; // sampling decodes to linear
constexpr VkFormat kClientColorFormat = VK_FORMAT_R16G16B16A16_SFLOAT;
constexpr VkFormat kClientDepthFormat = VK_FORMAT_D32_SFLOAT;

// An atlas rectangle waiting for the next frame: its texels at `offset` of Impl::pendingTexels.
struct PendingAtlasRegion {
  uint32_t x = 0, y = 0, width = 0, height = 0;
  size_t offset = 0;
};

struct AtlasClientRenderer::Impl {
  gpu::Context& ctx;
  AtlasClientConfig config;

  // Patch slots: the CPU copy of every slot's record (the GPU buffer's contents once the dirty
  // slots are uploaded), the slot of each id, slots freed for reuse, and the slots changed since
  // the last recorded frame (each listed once: dirtyFlag).
  std::vector<shaderio::GpuClientPatch> slots; // the slots ever used; the draws cover all of them
  std::unordered_map<uint32_t, uint32_t> slotOf;
  std::vector<uint32_t> freeSlots;
  std::vector<uint32_t> dirty;
  std::vector<uint8_t> dirtyFlag;
  uint32_t blendPatches = 0;   // BLEND patches set: the transparency passes run only with some
  uint64_t patchTriangles = 0; // over every patch set
  Bounds bounds;               // of every patch ever set (clip planes; never shrinks)
  gpu::Buffer patches;         // GpuClientPatch[config.maxPatches], device-local
  // Particles: the records every frame draws, copied per frame slot into particleRecords[slot].
  std::vector<shaderio::GpuClientParticle> particles;

  // The atlas and the uploads the next frame records.
  gpu::Image atlas;
  bool atlasDefined = false; // cleared once by the first frame (black), then SHADER_READ_ONLY between frames
  std::vector<PendingAtlasRegion> pendingRegions;
  std::vector<uint8_t> pendingTexels;
  gpu::Unique<VkSampler> sampler;
  gpu::DescriptorSet atlasDescriptors;

  gpu::Unique<VkPipelineLayout> layout, resolveLayout;
  gpu::Unique<VkPipeline> opaquePipeline, appendPipeline, particlePipeline, resolvePipeline;

  // The targets and the lists, shared by the slots (each frame's first barrier orders it after the
  // earlier ones).
  gpu::Image color, depth;
  uint32_t width = 0, height = 0;
  gpu::Buffer oitHeads, oitNodes, oitColors, oitCounters;
  uint32_t oitNodeCapacity = 0, oitNodesPerPixel = 0;
  bool oitNodesUnzeroed = false; // a new node pool, zeroed by the next frame (oit_list.glsl needs it all zero)

  // Per slot: what the CPU writes or reads while other frames run.
  gpu::Buffer frames[kMaxFramesInFlight];          // ViewFrame
  gpu::Buffer staging[kMaxFramesInFlight];         // the frame's patch records and atlas texels
  gpu::Buffer particleRecords[kMaxFramesInFlight]; // the frame's GpuClientParticle[] (host-visible)
  gpu::Buffer oitLists[kMaxFramesInFlight];        // OitLists
  gpu::Buffer oitReadback[kMaxFramesInFlight];     // OitCounters
  gpu::DescriptorSet resolveDescriptors[kMaxFramesInFlight];
  std::vector<gpu::GpuTimer> timers;
  FrameStats slotStats[kMaxFramesInFlight];
  bool slotOit[kMaxFramesInFlight] = {};
  bool recorded[kMaxFramesInFlight] = {};
  gpu::DeletionQueue retired; // targets replaced while frames in flight may still use them

  explicit Impl(gpu::Context& c, const AtlasClientConfig& cfg) : ctx(c), config(cfg) {
    for (uint32_t i = 0; i < kMaxFramesInFlight; ++i) timers.emplace_back(c);
  }
  uint32_t inFlight() const {
    uint32_t mask = 0;
    for (uint32_t i = 0; i < kMaxFramesInFlight; ++i) mask |= recorded[i] ? 1u << i : 0u;
    return mask;
  }

  // atlas_client.cpp
  void createResources();
  void markDirty(uint32_t slot);

  // atlas_client_frame.cpp
  void ensureTargets(uint32_t w, uint32_t h, uint32_t nodesPerPixel);
  // The pending patch records and atlas texels into the slot's staging buffer and from there to the
  // patch buffer and the atlas (after the frame's first barrier), made visible to the draws.
  void cmdUpload(VkCommandBuffer cmd, uint32_t slot);
  // Whether frames draw through the linked lists: some BLEND patch or particle.
  bool transparent() const { return blendPatches != 0 || !particles.empty(); }
  void cmdTransparency(VkCommandBuffer cmd, uint32_t slot, VkDeviceAddress frame, FrameStats& stats);
  // The draws' push constants (`records`: the patch slots, or the particle draw's records), culling,
  // viewport and atlas.
  void cmdBindDraw(VkCommandBuffer cmd, VkDeviceAddress frame, VkDeviceAddress records, uint32_t alphaModes,
                   VkDeviceAddress oit);
};

} // namespace mirage::render
