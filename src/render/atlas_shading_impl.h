#pragma once
// AtlasShading's state, shared by its files:
//   atlas_shading.cpp     upload, the shading stage, colour-only patches, readback
//   atlas_visibility.cpp  the visibility stage: its checks, the hardware method (depth prepass +
//                         marking pass per camera)
//   atlas_visibility_compute.cpp  the compute method (the cluster renderer's compute raster)
#include <vector>

#include "mirage/gpu/descriptors.h"
#include "mirage/gpu/memory.h"
#include "mirage/gpu/pipeline.h"
#include "mirage/gpu/query.h"
#include "mirage/render/atlas_shading.h"
#include "mirage/shaderio/atlas_shading.h"
#include "mirage/shaderio/forward.h"

namespace mirage::render {

constexpr VkFormat kAtlasFormat = VK_FORMAT_R8G8B8A8_UNORM; // holds sRGB-encoded bytes (encoded by the shader)
constexpr VkFormat kAtlasDepthFormat = VK_FORMAT_D32_SFLOAT;

struct AtlasMeshRange {
  uint32_t firstIndex = 0; // into the merged index buffer (mesh-local indices)
  uint32_t indexCount = 0;
  uint32_t firstVertex = 0; // into the merged vertex buffer
  uint32_t material = 0;    // clamped to the scene's materials
};

// A host-visible buffer that grows to what a call needs (shade()'s patches and tiles, colours).
struct AtlasHostBuffer {
  gpu::Buffer buffer;
  void ensure(gpu::Context& ctx, VkDeviceSize bytes, VkBufferUsageFlags usage, gpu::MemoryUsage memory,
              const char* name);
};

struct AtlasShading::Impl {
  gpu::Context& ctx;
  AtlasShadingConfig config;
  // Geometry as the forward renderer merges it; positions and indices also on the CPU (centroids
  // of colour-only patches).
  gpu::Buffer vertices, indices;
  std::vector<AtlasMeshRange> meshes;
  std::vector<glm::vec3> positions;  // merged
  std::vector<uint32_t> meshIndices; // merged, mesh-local
  uint32_t vertexCount = 0;
  // Instances in scene order and their first global triangle ids (size instances + 1).
  std::vector<Instance> instances;
  Bounds worldBounds; // clip planes of cameras that leave them zero
  std::vector<uint32_t> triangleOffsets;
  gpu::Buffer instanceBuffer, firstTriangleBuffer;
  // Materials, lights, textures (render_util.h's uploads).
  std::vector<Material> sceneMaterials;
  gpu::Buffer materials, mapTransforms, lights;
  uint32_t lightCount = 0;
  std::vector<gpu::Image> textures;
  gpu::Unique<VkSampler> sampler;
  gpu::DescriptorSet descriptors; // 0: bindless textures, 1: the atlas as a storage image
  // Patches: the map, and its inverse (patch -> its triangles, ascending) for colour-only patches.
  std::vector<uint32_t> patchOfTriangle;
  std::vector<uint32_t> patchFirst; // size patchCount + 1, into patchTriangles
  std::vector<uint32_t> patchTriangles;
  uint32_t patchCount = 0;
  gpu::Buffer patchOfTriangleBuffer, flags, flagsReadback;
  // Visibility targets and pipelines.
  gpu::Image depth;
  uint32_t depthWidth = 0, depthHeight = 0;
  gpu::Unique<VkPipelineLayout> visibilityLayout;
  gpu::Unique<VkPipeline> prepassOpaque, prepassMask, markEqual, markInFront;
  // Compute visibility (atlas_visibility_compute.cpp): the scene as clusters of at most
  // MIRAGE_CLUSTER_MAX_TRIANGLES consecutive mesh triangles in the cluster renderer's records, one
  // fixed visible list of every (instance, cluster): opaque and MASK entries (the depth raster's
  // list), then BLEND ones (the marking rasters take the whole list).
  AtlasVisibilityMethod visibilityMethod = AtlasVisibilityMethod::Hardware;
  struct ComputeVisibility {
    gpu::Buffer vertices, clusterVertices, indices, clusters, meshes, instances; // ClusterPush's arrays
    gpu::Buffer visible, entryTriangles, tables;
    gpu::Buffer counters;   // ClusterCounters per camera (the raster lists, the depth queue's counts)
    gpu::Buffer depthQueue; // BlendQueueTriangle[kAtlasDepthQueueCapacity] per camera
    gpu::Buffer frames;    // ClusterFrame per camera (host-written), MIRAGE_CLUSTER_FRAME_STRIDE apart
    gpu::Buffer visBuffer; // per camera: uint64_t per pixel, then the depth tiles (visPartBytes apart)
    VkDeviceSize visPartBytes = 0;
    gpu::Buffer patchBits, bitsReadback; // a bit per patch
    uint32_t opaqueEntries = 0, blendEntries = 0;
    bool hasMask = false;
    uint32_t visWidth = 0, visHeight = 0;
    gpu::Unique<VkPipelineLayout> rasterLayout, tilesLayout;
    gpu::Unique<VkPipeline> raster, rasterMask, mark, markMask, tiles, queueArgs, depthQueuePass;
  } cv;
  // Shading.
  gpu::Image atlas;
  gpu::Unique<VkPipelineLayout> computeLayout;
  gpu::Unique<VkPipeline> shadePipeline, colourPipeline, clearPipeline, yuvPipeline;
  gpu::Buffer frame; // FrameData (host-visible)
  AtlasHostBuffer patchBuffer, tileBuffer, sampleBuffer, colourBuffer, regionBuffer;
  AtlasHostBuffer uploadBuffer; // writeAtlasRegions' texels
  AtlasHostBuffer yuvScratch; // device-local: the YUV pass's output before its copy to the host

  // GPU time of each submission since the last takePassTimes().
  gpu::GpuTimer timer;
  std::vector<gpu::PassTime> passTimes;

  explicit Impl(gpu::Context& c) : ctx(c), timer(c, 8) {}
  // Records `record` between two timestamps named `name`, submits and waits, keeps the time.
  template <class F> void submitTimed(const char* name, F&& record) {
    ctx.submitAndWait([&](VkCommandBuffer cmd) {
      timer.cmdReset(cmd);
      uint32_t slot = timer.cmdBegin(cmd, name);
      record(cmd);
      timer.cmdEnd(cmd, slot);
    });
    for (gpu::PassTime& t : timer.read()) passTimes.push_back(std::move(t));
  }
  Status upload(const Scene& scene);
  void createPipelines();
  void writeFrame(const AtlasLighting& lighting, glm::vec3 eye);
  uint32_t instanceMaterial(uint32_t instance) const { return meshes[instances[instance].mesh].material; }
  // atlas_visibility.cpp
  void ensureDepth(uint32_t width, uint32_t height);
  std::vector<uint32_t> visibilityHardware(std::span<const Camera> cameras, uint32_t width, uint32_t height);
  // atlas_visibility_compute.cpp
  static bool computeVisibilitySupported(const gpu::Context& ctx);
  void uploadClusters(const Scene& scene, const std::vector<uint32_t>& firstVertex,
                      const std::vector<shaderio::GpuVertex>& merged);
  void createComputeVisibilityPipelines();
  std::vector<uint32_t> visibilityCompute(std::span<const Camera> cameras, uint32_t width, uint32_t height);
};

} // namespace mirage::render
