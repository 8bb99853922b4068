// The visibility stage's compute method (docs/stream.md, "Visibility stage"), the cluster
// renderer's compute raster (cluster_raster.glsl) over a fixed list of every (instance, cluster):
// per camera, into its own part of one 64-bit visibility buffer,
//   1. the depth raster: OPAQUE and MASK clusters, nearest sample per pixel (atomicMax);
//   2. the marking rasters (atlas_visibility_mark*.comp): every cluster again; a sample not behind
//      the nearest depth (less MIRAGE_ATLAS_DEPTH_TOLERANCE of it) sets its patch's bit: BLEND
//      layers in front, and the nearest surfaces with those that tie with them;
// The buffer is filled with zeros first (16 MB per camera at 1080p), the bits (one per patch) are
// read back. Four dispatches a frame for two cameras (eight with MASK materials) whatever the
// instance count; no per-instance draws, no depth attachments.
#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>
#include <limits>

#include <glm/gtc/matrix_inverse.hpp>

#include "atlas_shading_impl.h"
#include "cluster_impl.h"
#include "forward_impl.h"
#include "mirage/gpu/commands.h"
#include "mirage/shaderio/cluster.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

namespace {

// The cluster renderer's mono raster specialization.
constexpr uint32_t kMono[] = {1, kClusterRasterLanes};
// The depth raster's global queue (atlas_visibility_depth.comp): opaque triangles whose pixel box
// exceeds kAtlasDepthQueuePixels, at most kAtlasDepthQueueCapacity per camera (past it they are
// walked by their cluster's workgroup, as without the queue).
constexpr uint32_t kAtlasDepthQueueCapacity = 16384;
constexpr float kAtlasDepthQueuePixels = 1024.0f;

// Workgroups for `count` in x, spilling into y past 65535 (the raster's MIRAGE_CLUSTER_DISPATCH_X).
VkExtent2D groups(uint32_t count) {
  uint32_t x = std::min<uint32_t>(count, MIRAGE_CLUSTER_DISPATCH_X);
  return {x, x == 0 ? 0 : (count + x - 1) / x};
}

} // namespace

bool AtlasShading::Impl::computeVisibilitySupported(const Context& ctx) {
  return ctx.caps().int64BufferAtomics && ctx.caps().int64SharedAtomics; // the compute raster's atomics
}

// Clusters of each mesh: its triangles in order, a cluster closed at MIRAGE_CLUSTER_MAX_TRIANGLES
// triangles or before its vertices pass MIRAGE_CLUSTER_MAX_VERTICES, so cluster triangle t of a
// list entry is global triangle entryTriangle[entry] + t.
void AtlasShading::Impl::uploadClusters(const Scene& scene, const std::vector<uint32_t>& firstVertex,
                                        const std::vector<sio::GpuVertex>& merged) {
  std::vector<sio::GpuClusterVertex> vertexData(merged.size());
  for (size_t i = 0; i < merged.size(); ++i) vertexData[i] = {merged[i].position, merged[i].normal, merged[i].uv};
  std::vector<sio::GpuCluster> clusterData;
  std::vector<uint32_t> clusterVertexIds, clusterFirstTriangle; // per cluster: its first mesh triangle
  std::vector<uint8_t> localIndices;
  std::vector<uint32_t> meshFirstCluster(scene.meshes.size() + 1, 0);
  for (size_t k = 0; k < scene.meshes.size(); ++k) {
    const Mesh& mesh = scene.meshes[k];
    std::vector<int32_t> local(mesh.positions.size(), -1);
    std::vector<uint32_t> used; // mesh vertices of the open cluster
    uint32_t triangles = uint32_t(mesh.triangleCount());
    for (uint32_t t = 0; t < triangles;) {
      sio::GpuCluster c{};
      c.vertexOffset = uint32_t(clusterVertexIds.size());
      c.triangleOffset = uint32_t(localIndices.size() / 3);
      c.mesh = uint32_t(k);
      c.cluster = uint32_t(clusterData.size());
      c.cone.axisCutoff.w = 1.0f; // never culled
      c.parentError = std::numeric_limits<float>::infinity();
      c.maxEdge = std::numeric_limits<float>::infinity(); // the lean raster is not used
      clusterFirstTriangle.push_back(t);
      glm::vec3 lo(std::numeric_limits<float>::max()), hi(-std::numeric_limits<float>::max());
      for (; t < triangles && c.triangleCount < MIRAGE_CLUSTER_MAX_TRIANGLES; ++t) {
        uint32_t fresh = 0;
        for (int j = 0; j < 3; ++j) fresh += local[mesh.indices[t * 3 + j]] < 0;
        if (used.size() + fresh > MIRAGE_CLUSTER_MAX_VERTICES) break;
        for (int j = 0; j < 3; ++j) {
          uint32_t v = mesh.indices[t * 3 + j];
          if (local[v] < 0) {
            local[v] = int32_t(used.size());
            used.push_back(v);
            clusterVertexIds.push_back(firstVertex[k] + v);
            lo = glm::min(lo, mesh.positions[v]);
            hi = glm::max(hi, mesh.positions[v]);
          }
          localIndices.push_back(uint8_t(local[v]));
        }
        c.triangleCount++;
      }
      c.vertexCount = uint32_t(used.size());
      glm::vec3 centre = 0.5f * (lo + hi);
      float radius = 0.0f;
      for (uint32_t v : used) radius = std::max(radius, glm::length(mesh.positions[v] - centre));
      c.boundsSphere = c.selfSphere = c.parentSphere = glm::vec4(centre, radius);
      clusterData.push_back(c);
      for (uint32_t v : used) local[v] = -1;
      used.clear();
    }
    meshFirstCluster[k + 1] = uint32_t(clusterData.size());
  }
  localIndices.resize((localIndices.size() + 3) / 4 * 4, 0);
  std::vector<uint32_t> packedIndices(localIndices.size() / 4);
  std::memcpy(packedIndices.data(), localIndices.data(), localIndices.size());

  std::vector<sio::GpuClusterMesh> meshData(scene.meshes.size());
  for (size_t k = 0; k < scene.meshes.size(); ++k) {
    meshData[k].clusterOffset = meshFirstCluster[k];
    meshData[k].clusterCount = meshFirstCluster[k + 1] - meshFirstCluster[k];
    meshData[k].material = meshes[k].material;
  }
  std::vector<sio::GpuClusterInstance> instanceData;
  std::vector<sio::VisibleCluster> opaque, blend;
  std::vector<uint32_t> opaqueTriangles, blendTriangles;
  for (uint32_t i = 0; i < instances.size(); ++i) {
    const Instance& inst = instances[i];
    const Material& m = sceneMaterials[instanceMaterial(i)];
    sio::GpuClusterInstance gi{};
    gi.model = inst.transform;
    gi.normalMatrix = glm::inverseTranspose(inst.transform);
    gi.mesh = inst.mesh;
    gi.maxScale = maxAxisScale(inst.transform);
    gi.flags = clusterInstanceFlags(m, inst.transform);
    instanceData.push_back(gi);
    cv.hasMask |= m.alphaMode == AlphaMode::Mask;
    bool isBlend = m.alphaMode == AlphaMode::Blend;
    for (uint32_t c = meshFirstCluster[inst.mesh]; c < meshFirstCluster[inst.mesh + 1]; ++c) {
      (isBlend ? blend : opaque).push_back({i, c});
      (isBlend ? blendTriangles : opaqueTriangles).push_back(triangleOffsets[i] + clusterFirstTriangle[c]);
    }
  }
  cv.opaqueEntries = uint32_t(opaque.size());
  cv.blendEntries = uint32_t(blend.size());
  opaque.insert(opaque.end(), blend.begin(), blend.end());
  opaqueTriangles.insert(opaqueTriangles.end(), blendTriangles.begin(), blendTriangles.end());

  const VkBufferUsageFlags kStorage = VK_BUFFER_USAGE_STORAGE_BUFFER_BIT;
  cv.vertices = createBufferWithData<sio::GpuClusterVertex>(ctx, vertexData, kStorage, "atlas cluster vertices");
  cv.clusterVertices = createBufferWithData<uint32_t>(ctx, clusterVertexIds, kStorage, "atlas cluster vertex ids");
  cv.indices = createBufferWithData<uint32_t>(ctx, packedIndices, kStorage, "atlas cluster indices");
  cv.clusters = createBufferWithData<sio::GpuCluster>(ctx, clusterData, kStorage, "atlas clusters");
  cv.meshes = createBufferWithData<sio::GpuClusterMesh>(ctx, meshData, kStorage, "atlas cluster meshes");
  cv.instances = createBufferWithData<sio::GpuClusterInstance>(ctx, instanceData, kStorage, "atlas cluster instances");
  cv.visible = createBufferWithData<sio::VisibleCluster>(ctx, opaque, kStorage, "atlas visible clusters");
  cv.entryTriangles = createBufferWithData<uint32_t>(ctx, opaqueTriangles, kStorage, "atlas entry triangles");
  // The raster passes' lists: pass 0 (depth) the opaque and MASK entries, pass 1 (marking) every
  // entry (only trianglesNearClipped is ever written).
  sio::ClusterCounters counters{};
  counters.lists[0][MIRAGE_LIST_UP].first = 0;
  counters.lists[0][MIRAGE_LIST_UP].count = cv.opaqueEntries;
  counters.lists[1][MIRAGE_LIST_UP].first = 0;
  counters.lists[1][MIRAGE_LIST_UP].count = cv.opaqueEntries + cv.blendEntries;
  const sio::ClusterCounters perCamera[2] = {counters, counters};
  cv.counters = createBufferWithData<sio::ClusterCounters>(
      ctx, perCamera, kStorage | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_INDIRECT_BUFFER_BIT,
      "atlas raster counters");
  cv.depthQueue = createBuffer(ctx, 2 * VkDeviceSize(kAtlasDepthQueueCapacity) * sizeof(sio::BlendQueueTriangle),
                               kStorage, MemoryUsage::GpuOnly, "atlas depth queue");
  uint32_t words = (patchCount + 31) / 32;
  cv.patchBits = createBuffer(ctx, std::max<VkDeviceSize>(VkDeviceSize(words) * 4, 4),
                              kStorage | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                              MemoryUsage::GpuOnly, "atlas patch bits");
  cv.bitsReadback = createBuffer(ctx, std::max<VkDeviceSize>(VkDeviceSize(words) * 4, 4),
                                 VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::Readback, "atlas patch bits readback");
  sio::AtlasVisibilityTables tables{cv.entryTriangles.address(), patchOfTriangleBuffer.address(),
                                    cv.patchBits.address()};
  cv.tables = createBufferWithData<sio::AtlasVisibilityTables>(ctx, {&tables, 1}, kStorage, "atlas visibility tables");
  cv.frames = createBuffer(ctx, 2 * MIRAGE_CLUSTER_FRAME_STRIDE, kStorage, MemoryUsage::Upload, "atlas raster frames");
}

void AtlasShading::Impl::createComputeVisibilityPipelines() {
  cv.rasterLayout =
      createPipelineLayout(ctx, {descriptors.layout.get()}, sizeof(sio::ClusterPush), VK_SHADER_STAGE_COMPUTE_BIT);
  cv.raster = createComputePipeline(ctx, "atlas_visibility_depth.comp", cv.rasterLayout, kMono);
  cv.queueArgs = createComputePipeline(ctx, "cluster_args.comp", cv.rasterLayout);
  cv.depthQueuePass = createComputePipeline(ctx, "atlas_visibility_depth_queue.comp", cv.rasterLayout);
  if (cv.hasMask) cv.rasterMask = createComputePipeline(ctx, "cluster_raster_mask.comp", cv.rasterLayout, kMono);
  cv.mark = createComputePipeline(ctx, "atlas_visibility_mark.comp", cv.rasterLayout, kMono);
  cv.tilesLayout = createPipelineLayout(ctx, {descriptors.layout.get()}, sizeof(sio::AtlasDepthTilesPush),
                                        VK_SHADER_STAGE_COMPUTE_BIT);
  cv.tiles = createComputePipeline(ctx, "atlas_visibility_tiles.comp", cv.tilesLayout);
  if (cv.hasMask) cv.markMask = createComputePipeline(ctx, "atlas_visibility_mark_mask.comp", cv.rasterLayout, kMono);
}

std::vector<uint32_t> AtlasShading::Impl::visibilityCompute(std::span<const Camera> cameras, uint32_t width,
                                                            uint32_t height) {
  const VkDeviceSize pixels = VkDeviceSize(width) * height;
  const uint32_t tilesX = (width + MIRAGE_ATLAS_DEPTH_TILE - 1) / MIRAGE_ATLAS_DEPTH_TILE;
  const uint32_t tilesY = (height + MIRAGE_ATLAS_DEPTH_TILE - 1) / MIRAGE_ATLAS_DEPTH_TILE;
  if (!cv.visBuffer || width != cv.visWidth || height != cv.visHeight) {
    cv.visPartBytes = pixels * 8 + (VkDeviceSize(tilesX) * tilesY * 4 + 7) / 8 * 8;
    cv.visBuffer =
        createBuffer(ctx, 2 * cv.visPartBytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                     MemoryUsage::GpuOnly, "atlas visibility buffer");
    cv.visWidth = width;
    cv.visHeight = height;
  }
  for (size_t e = 0; e < cameras.size(); ++e) {
    sio::ClusterFrame f{};
    f.camera = viewFrame(withClipPlanes(cameras[e], worldBounds), width, height);
    f.visibleCapacity = cv.opaqueEntries + cv.blendEntries;
    f.instanceCount = uint32_t(instances.size());
    f.blendQueueAddress = cv.depthQueue.address() + e * kAtlasDepthQueueCapacity * sizeof(sio::BlendQueueTriangle);
    f.blendQueueCapacity = kAtlasDepthQueueCapacity;
    f.blendQueuePixels = kAtlasDepthQueuePixels;
    std::memcpy(static_cast<uint8_t*>(cv.frames.mapped()) + e * MIRAGE_CLUSTER_FRAME_STRIDE, &f, sizeof(f));
  }
  sio::ClusterPush push{};
  push.clusterAddress = cv.clusters.address();
  push.vertexAddress = cv.vertices.address();
  push.clusterVertexAddress = cv.clusterVertices.address();
  push.indexAddress = cv.indices.address();
  push.meshAddress = cv.meshes.address();
  push.instanceAddress = cv.instances.address();
  push.materialAddress = materials.address();
  push.visibleInstanceAddress = cv.tables.address(); // the marking rasters' tables (atlas_visibility_mark.glsl)
  push.visibleAddress = cv.visible.address();
  const uint32_t words = (patchCount + 31) / 32;

  submitTimed("visibility", [&](VkCommandBuffer cmd) {
    // The bits and the cameras' parts of the buffer start at zero (the previous call's rasters and
    // copy read them: write after read, ordered by its wait).
    uint32_t part = timer.cmdBegin(cmd, "visibility.clear");
    vkCmdFillBuffer(cmd, cv.patchBits.handle(), 0, VkDeviceSize(words) * 4, 0);
    vkCmdFillBuffer(cmd, cv.visBuffer.handle(), 0, cameras.size() * cv.visPartBytes, 0);
    for (size_t e = 0; e < cameras.size(); ++e) // the depth queue starts empty
      vkCmdFillBuffer(cmd, cv.counters.handle(),
                      e * sizeof(sio::ClusterCounters) + offsetof(sio::ClusterCounters, blendQueueCounts),
                      sizeof(uint64_t), 0);
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, kCS, kStorageRW);
    timer.cmdEnd(cmd, part);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, cv.rasterLayout, 0, 1, &descriptors.set, 0, nullptr);
    // Each camera's samples into its own part of the buffer: the dispatches of both cameras overlap.
    auto rasterPass = [&](VkPipeline pipeline, uint32_t list, uint32_t entries) {
      if (!pipeline || entries == 0) return;
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
      for (size_t e = 0; e < cameras.size(); ++e) {
        push.frameAddress = cv.frames.address() + e * MIRAGE_CLUSTER_FRAME_STRIDE;
        push.visBufferAddress = cv.visBuffer.address() + e * cv.visPartBytes;
        push.counterAddress = cv.counters.address() + e * sizeof(sio::ClusterCounters);
        push.rasterList = list * 2 + MIRAGE_LIST_UP;
        vkCmdPushConstants(cmd, cv.rasterLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
        VkExtent2D g = groups(entries);
        vkCmdDispatch(cmd, g.width, g.height, 1);
      }
    };
    const uint32_t all = cv.opaqueEntries + cv.blendEntries;
    part = timer.cmdBegin(cmd, "visibility.depth");
    rasterPass(cv.raster, 0, cv.opaqueEntries);
    rasterPass(cv.rasterMask, 0, cv.opaqueEntries); // the MASK entries of the same list (the opaque kernel skips them)
    // The opaque raster's queued large triangles, their tiles over many workgroups.
    cmdMemoryBarrier(cmd, kCS, kStorageRW, kCS, kStorageRW);
    auto perCamera = [&](VkPipeline pipeline, auto&& dispatch) {
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
      for (size_t e = 0; e < cameras.size(); ++e) {
        push.frameAddress = cv.frames.address() + e * MIRAGE_CLUSTER_FRAME_STRIDE;
        push.visBufferAddress = cv.visBuffer.address() + e * cv.visPartBytes;
        push.counterAddress = cv.counters.address() + e * sizeof(sio::ClusterCounters);
        push.rasterList = MIRAGE_BLEND_QUEUE_ARGS;
        vkCmdPushConstants(cmd, cv.rasterLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
        dispatch(e);
      }
    };
    perCamera(cv.queueArgs, [&](size_t) { vkCmdDispatch(cmd, 1, 1, 1); });
    cmdMemoryBarrier(cmd, kCS, kStorageRW, VK_PIPELINE_STAGE_2_DRAW_INDIRECT_BIT | kCS,
                     VK_ACCESS_2_INDIRECT_COMMAND_READ_BIT | kStorageRW);
    perCamera(cv.depthQueuePass, [&](size_t e) {
      vkCmdDispatchIndirect(cmd, cv.counters.handle(),
                            e * sizeof(sio::ClusterCounters) + offsetof(sio::ClusterCounters, blendQueueArgs));
    });
    cmdMemoryBarrier(cmd, kCS, kStorageRW, kCS, kStorageRW); // the nearest depths are final
    timer.cmdEnd(cmd, part);
    part = timer.cmdBegin(cmd, "visibility.tiles");
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, cv.tiles);
    for (size_t e = 0; e < cameras.size(); ++e) {
      sio::AtlasDepthTilesPush tp{cv.visBuffer.address() + e * cv.visPartBytes, width, height};
      vkCmdPushConstants(cmd, cv.tilesLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(tp), &tp);
      vkCmdDispatch(cmd, tilesX, tilesY, 1);
    }
    cmdMemoryBarrier(cmd, kCS, kStorageRW, kCS, kStorageRW); // the tiles are final
    timer.cmdEnd(cmd, part);
    part = timer.cmdBegin(cmd, "visibility.mark");
    rasterPass(cv.mark, 1, all); // read the buffer, set bits
    rasterPass(cv.markMask, 1, all);
    timer.cmdEnd(cmd, part);
    cmdMemoryBarrier(cmd, kCS, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_PIPELINE_STAGE_2_COPY_BIT,
                     VK_ACCESS_2_TRANSFER_READ_BIT);
    VkBufferCopy region{0, 0, VkDeviceSize(words) * 4};
    vkCmdCopyBuffer(cmd, cv.patchBits.handle(), cv.bitsReadback.handle(), 1, &region);
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                     VK_ACCESS_2_HOST_READ_BIT);
  });
  std::vector<uint32_t> bits(words);
  std::memcpy(bits.data(), cv.bitsReadback.mapped(), size_t(words) * 4);
  std::vector<uint32_t> visible;
  for (uint32_t w = 0; w < words; ++w)
    for (uint32_t b = bits[w]; b != 0; b &= b - 1) visible.push_back(w * 32 + uint32_t(std::countr_zero(b)));
  return visible;
}

} // namespace mirage::render
