#pragma once
// ForwardRenderer's state, shared by its files:
//   forward_renderer.cpp  upload, opaque pipeline, targets, frame recording
//   forward_oit.cpp       transparency: linked lists, weighted blended, sorted triangles
#include <algorithm>
#include <vector>

#include "mirage/gpu/deletion_queue.h"
#include "mirage/gpu/descriptors.h"
#include "mirage/gpu/pipeline.h"
#include "mirage/render/forward_renderer.h"
#include "mirage/render/particle_draw.h"
#include "mirage/shaderio/forward.h"

namespace mirage::render {

constexpr VkFormat kForwardColorFormat = VK_FORMAT_R16G16B16A16_SFLOAT; // linear HDR, converted on readback
constexpr VkFormat kForwardDepthFormat = VK_FORMAT_D32_SFLOAT;
constexpr VkFormat kForwardAccumFormat =
    VK_FORMAT_R16G16B16A16_SFLOAT; // both weighted targets: blend + storage guaranteed

// Weighted blending's one state for both targets (no independentBlend needed): colour channels
// add (ONE, ONE), alpha multiplies by 1 - a (ZERO, ONE_MINUS_SRC_ALPHA), so target 0 gathers
// (sum of rgb a w, revealage) and target 1 (sum of a w in r). Scene geometry and particles share it.
VkPipelineColorBlendAttachmentState forwardWeightedBlend();

struct ForwardMeshRange {
  uint32_t firstIndex = 0;
  uint32_t indexCount = 0;
  int32_t vertexOffset = 0;
  uint32_t material = 0;
  Bounds bounds;
};

// The indices one draw reads from the bound index buffer: a whole mesh, or an instance's triangles
// in the visible set's buffer (setVisibleTriangles). The mesh gives the material and vertex offset.
struct ForwardDrawRange {
  uint32_t mesh = 0;
  uint32_t firstIndex = 0;
  uint32_t indexCount = 0;
};

// Opaque and masked instances of one range, drawn with one instanced call.
struct ForwardBatch {
  ForwardDrawRange range;
  bool mirrored = false; // negative-determinant transform: glTF flips the winding
  uint32_t firstInstance = 0;
  uint32_t instanceCount = 0;
};

// A run of the sorted mode's triangle order: consecutive triangles of one blend instance.
struct SortedRun {
  uint32_t blendInstance = 0;
  uint32_t firstIndex = 0; // into the slot's sorted index buffer
  uint32_t indexCount = 0;
};

// A BLEND instance's listed triangles in the visible set.
struct ForwardBlendRange {
  uint32_t blendInstance = 0;      // into Impl::blendInstances
  ForwardDrawRange range;          // linked lists and weighted: into the visible set's indices
  std::vector<uint32_t> triangles; // the sorted mode: the mesh's listed triangles, ascending
};

// The triangles setVisibleTriangles listed: per instance with any, one draw of just those, their
// indices copied out of the scene's index buffer by the next frame recorded.
struct ForwardVisibleSet {
  bool active = false;
  gpu::Buffer indices;   // each draw's indices contiguous (opaque and blended)
  gpu::Buffer instances; // GpuInstance of each opaque draw (its firstInstance)
  std::vector<ForwardBatch> batches;
  std::vector<ForwardBlendRange> blend;
  std::vector<VkBufferCopy> pendingCopies; // scene indices -> `indices`, not yet recorded
};

struct ForwardRenderer::Impl {
  gpu::Context& ctx;
  gpu::Buffer vertices, indices, materials, instanceBuffer; // instanceBuffer: opaque and masked instances
  gpu::Buffer mapTransforms;                                // the materials' map transforms (uploadMaterials)
  gpu::Buffer lights; // GpuPointLight[lightCount] (one unused entry when the scene has none)
  uint32_t lightCount = 0;
  std::vector<gpu::Image> textures;
  gpu::Unique<VkSampler> sampler;
  gpu::DescriptorSet descriptors; // bindless material textures
  gpu::Unique<VkPipelineLayout> layout;
  gpu::Unique<VkPipeline> opaquePipeline;
  std::vector<ForwardMeshRange> meshes;
  std::vector<Material> sceneMaterials;
  std::vector<Instance> sceneInstances; // in scene order (setVisibleTriangles' IDs count through them)
  std::vector<ForwardBatch> batches;    // opaque + mask, the whole scene
  ForwardVisibleSet visible;            // drawn instead of the whole scene when active

  // Transparency (forward_oit.cpp). The BLEND instances in scene order, their GpuInstance data, and
  // for the sorted mode their meshes' positions and indices on the CPU.
  std::vector<Instance> blendInstances;
  gpu::Buffer blendInstanceBuffer;
  std::vector<std::vector<glm::vec3>> blendPositions; // per mesh, empty for meshes no blend instance uses
  std::vector<std::vector<uint32_t>> blendIndices;
  uint64_t blendTriangles = 0; // over all blend instances
  gpu::Unique<VkPipeline> sortedPipeline, appendPipeline, weightedPipeline, resolvePipeline, weightedResolvePipeline;
  gpu::Unique<VkPipelineLayout> resolveLayout;
  // Per slot: written at the start of its frame's recording (before any bind), the colour at binding
  // 0 and the weighted targets at 1 and 2 (writeResolveSet).
  gpu::DescriptorSet resolveDescriptors[kMaxFramesInFlight];
  // The targets' clears (forward_renderer.cpp, "Clears"): the colour (and the weighted targets) by
  // compute stores through the resolve sets, the depth copied from an image of far depth.
  gpu::Unique<VkPipelineLayout> clearLayout;
  gpu::Unique<VkPipeline> clearPipeline, weightedClearPipeline;
  gpu::Image depthFar;        // the depth's size, all 0 (reverse-Z far), in TRANSFER_SRC_OPTIMAL once set
  bool depthFarUnset = false; // made with the targets, cleared by the next frame
  // Linked lists: heads and pool shared by the slots (each frame's first barrier orders it), the
  // counters copied per slot into readback.
  gpu::Buffer oitHeads, oitNodes, oitColors, oitCounters;
  uint32_t oitNodeCapacity = 0, oitNodesPerPixel = 0;
  bool oitNodesUnzeroed = false; // a new node pool, zeroed by the next frame (oit_list.glsl needs it all zero)
  gpu::Image accum, reveal;      // weighted: (sum rgb a w, revealage), (sum a w, -, -, -)
  gpu::Buffer splatAccum;        // the particle splat's sums (ParticleDraw::splatBytes), made on first use

  // The targets, shared by every slot (each frame's first barrier orders it after the earlier
  // ones); colorWidth is both eyes' in stereo.
  gpu::Image color, depth;
  uint32_t colorWidth = 0, height = 0;
  uint32_t eyeWidth = 0; // the recorded frame's per-eye width
  // Per slot: what the CPU writes or reads while other frames run.
  gpu::Buffer frames[kMaxFramesInFlight];        // FrameData per eye
  gpu::Buffer oitLists[kMaxFramesInFlight];      // OitLists
  gpu::Buffer oitReadback[kMaxFramesInFlight];   // OitCounters
  gpu::Buffer sortedIndices[kMaxFramesInFlight]; // sorted mode: blend triangles back to front
  std::vector<SortedRun> sortedRuns[kMaxFramesInFlight];
  // Sorted mode with particles: the sorted triangles' view z (float, ascending) and the particle
  // draw of each gap between them (VkDrawIndirectCommand[blendTriangles + 1], ParticleDraw::cmdSort).
  gpu::Buffer sortedDepths[kMaxFramesInFlight], sortedGaps[kMaxFramesInFlight];
  bool slotSortsParticles[kMaxFramesInFlight] = {}; // the slot's frame interleaves particles with triangles
  bool slotOit[kMaxFramesInFlight] = {};            // the slot's frame ran the linked lists (counters to read)
  std::vector<gpu::GpuTimer> timers;
  std::vector<gpu::PipelineStatsQuery> stats;
  FrameStats slotStats[kMaxFramesInFlight]; // draw counts of the recorded frame
  bool recorded[kMaxFramesInFlight] = {};
  gpu::DeletionQueue retired; // targets replaced while frames in flight may still draw into them

  explicit Impl(gpu::Context& c) : ctx(c) {
    for (uint32_t i = 0; i < kMaxFramesInFlight; ++i) timers.emplace_back(c), stats.emplace_back(c);
  }

  void upload(const Scene& scene);
  void createPipelines();
  void ensureTargets(uint32_t colorW, uint32_t h);
  // Sets eye e's viewport and scissor (its half of the target in stereo); returns its FrameData.
  VkDeviceAddress cmdSetEye(VkCommandBuffer cmd, uint32_t slot, uint32_t eye) const;
  void cmdBindMeshDraw(VkCommandBuffer cmd, VkDeviceAddress frame, VkDeviceAddress instances, uint32_t mesh,
                       bool mirrored, VkDeviceAddress oit);
  // The range's indices of the bound index buffer, as mesh range.mesh's (its vertices and material).
  void cmdDraw(VkCommandBuffer cmd, VkDeviceAddress frame, VkDeviceAddress instances, const ForwardDrawRange& range,
               bool mirrored, uint32_t firstInstance, uint32_t count, FrameStats& fs, VkDeviceAddress oit = 0);
  ForwardDrawRange wholeMesh(uint32_t mesh) const { return {mesh, meshes[mesh].firstIndex, meshes[mesh].indexCount}; }
  bool isBlend(uint32_t mesh) const {
    return sceneMaterials[std::min<size_t>(meshes[mesh].material, sceneMaterials.size() - 1)].alphaMode ==
           AlphaMode::Blend;
  }
  uint32_t inFlight() const {
    uint32_t mask = 0;
    for (uint32_t i = 0; i < kMaxFramesInFlight; ++i) mask |= recorded[i] ? 1u << i : 0u;
    return mask;
  }

  // The slot's resolve set: the colour, and the weighted targets with fs.oit weighted.
  void writeResolveSet(uint32_t slot, OitMode oit);
  // The colour to `background` and the depth to far, both left in attachment layouts with the
  // clears visible to the opaque pass (targets in any layout before).
  void cmdClearTargets(VkCommandBuffer cmd, uint32_t slot, const glm::vec4& background);
  // The pass of the resolve set's compute clears: clearLayout and the given pipeline bound.
  void cmdClearDispatch(VkCommandBuffer cmd, uint32_t slot, VkPipeline pipeline, const glm::vec4& value);

  // forward_oit.cpp
  // Whether the frame splats particles (fs.particles with records, in a mode that splats), and
  // where: the slot's eyes, targets and timer.
  bool splatsParticles(const ForwardRenderSettings& fs) const;
  ParticleSplatTarget splatTarget(uint32_t slot, uint32_t eyeCount);
  void uploadTransparency(const Scene& scene);
  void ensureOitTargets(uint32_t nodesPerPixel);
  // Before the frame's render passes: zeroes the lists, writes the slot's OitLists and (sorted) its
  // triangle order from the eye-0 camera.
  void prepareTransparency(VkCommandBuffer cmd, const ForwardRenderSettings& fs, uint32_t slot, const glm::mat4& view);
  // After the opaque pass (colour and depth in attachment layouts, depth stored): the blended
  // geometry by fs.oit, leaving the colour in GENERAL with its writes visible to compute and transfer.
  void cmdTransparency(VkCommandBuffer cmd, const ForwardRenderSettings& fs, uint32_t slot, uint32_t eyeCount,
                       FrameStats& frameStats);
};

shaderio::GpuInstance makeGpuInstance(const glm::mat4& model);
bool isMirrored(const glm::mat4& model); // negative determinant: the winding flips

} // namespace mirage::render
