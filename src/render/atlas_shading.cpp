#include "mirage/render/atlas_shading.h"

#include <algorithm>
#include <utility>
#include <array>
#include <cstring>
#include <limits>
#include <optional>

#include <fmt/format.h>

#include "atlas_shading_impl.h"
#include "forward_impl.h"
#include "mirage/gpu/commands.h"
#include "render_util.h"

namespace mirage::render {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

namespace {

constexpr uint32_t kSuperblockSide = 1u << MIRAGE_ATLAS_MAX_BLOCK_LOG2;
// convertAtlasYuv's grid covers every atlas side exactly (a side is a multiple of the superblock).
static_assert(kSuperblockSide % (MIRAGE_ATLAS_YUV_RUN * MIRAGE_ATLAS_YUV_GROUP) == 0 &&
              kSuperblockSide % (2 * MIRAGE_ATLAS_YUV_GROUP) == 0);

} // namespace

std::vector<uint32_t> atlasMeshFirstVertex(const Scene& scene) {
  std::vector<uint32_t> first;
  uint32_t next = 0; // mergeSceneGeometry's firstVertex, without building the vertices
  for (const Mesh& m : scene.meshes) first.push_back(next), next += uint32_t(m.positions.size());
  return first;
}

void AtlasHostBuffer::ensure(Context& ctx, VkDeviceSize bytes, VkBufferUsageFlags usage, MemoryUsage memory,
                             const char* name) {
  if (buffer && buffer.size() >= bytes) return;
  VkDeviceSize size = std::max<VkDeviceSize>(bytes, buffer ? buffer.size() * 2 : 4096);
  buffer = createBuffer(ctx, size, usage, memory, name);
}

Status AtlasShading::Impl::upload(const Scene& scene) {
  uint64_t triangles = 0;
  for (size_t i = 0; i < scene.instances.size(); ++i) {
    if (scene.instances[i].mesh >= scene.meshes.size())
      return Error{fmt::format("{}: instance {} refers to mesh {} of {}", scene.source, i, scene.instances[i].mesh,
                               scene.meshes.size())};
    triangles += scene.meshes[scene.instances[i].mesh].triangleCount();
  }
  uint64_t vertexTotal = 0, indexTotal = 0;
  for (const Mesh& m : scene.meshes) vertexTotal += m.positions.size(), indexTotal += m.indices.size();
  if (triangles >= UINT32_MAX || vertexTotal >= UINT32_MAX || indexTotal >= UINT32_MAX)
    return Error{scene.source + ": the scene exceeds 32-bit triangle, vertex or index ids"};
  if (patchOfTriangle.size() != triangles)
    return Error{fmt::format("{}: the patch map lists {} triangles, the scene's instances have {}", scene.source,
                             patchOfTriangle.size(), triangles)};

  sceneMaterials = scene.materials;
  if (sceneMaterials.empty()) sceneMaterials.push_back(Material{});
  // Geometry merged as the forward renderer merges it (GpuAtlasPatch::vertices index it).
  MergedGeometry merged = mergeSceneGeometry(scene);
  for (size_t k = 0; k < scene.meshes.size(); ++k)
    meshes.push_back({merged.firstIndex[k], uint32_t(scene.meshes[k].indices.size()), merged.firstVertex[k],
                      std::min<uint32_t>(scene.meshes[k].material, uint32_t(sceneMaterials.size() - 1))});
  for (const sio::GpuVertex& v : merged.vertices) positions.push_back(v.position);
  meshIndices = std::move(merged.indices);
  vertexCount = uint32_t(merged.vertices.size());
  vertices = createBufferWithData<sio::GpuVertex>(
      ctx, merged.vertices, VK_BUFFER_USAGE_VERTEX_BUFFER_BIT | VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "atlas vertices");
  indices = createBufferWithData<uint32_t>(ctx, meshIndices, VK_BUFFER_USAGE_INDEX_BUFFER_BIT, "atlas indices");

  materials = uploadMaterials(ctx, sceneMaterials, scene.textures.size(), mapTransforms, "atlas materials");
  lights = uploadLights(ctx, scene.lights, "atlas lights");
  lightCount = uint32_t(scene.lights.size());
  textures = uploadTextures(ctx, scene);
  sampler = makeSampler(ctx, VK_FILTER_LINEAR);

  instances = scene.instances;
  worldBounds = scene.worldBounds();
  std::vector<sio::GpuInstance> instanceData;
  triangleOffsets = {0};
  for (const Instance& inst : instances) {
    instanceData.push_back(makeGpuInstance(inst.transform));
    triangleOffsets.push_back(triangleOffsets.back() + uint32_t(scene.meshes[inst.mesh].triangleCount()));
  }
  instanceBuffer =
      createBufferWithData<sio::GpuInstance>(ctx, instanceData, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "atlas instances");
  firstTriangleBuffer =
      createBufferWithData<uint32_t>(ctx, triangleOffsets, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "atlas first triangles");

  // A patch holds at least one triangle, so ids below the triangle count suffice (and bound the
  // flag buffer).
  for (size_t t = 0; t < patchOfTriangle.size(); ++t)
    if (patchOfTriangle[t] >= patchOfTriangle.size())
      return Error{fmt::format("{}: triangle {} maps to patch {}, beyond the {} patches its triangles allow",
                               scene.source, t, patchOfTriangle[t], patchOfTriangle.size())};
  // The patch map and its inverse (counting sort: each patch's triangles ascending).
  for (uint32_t p : patchOfTriangle) patchCount = std::max(patchCount, p + 1);
  patchFirst.assign(size_t(patchCount) + 1, 0);
  for (uint32_t p : patchOfTriangle) patchFirst[p + 1]++;
  for (uint32_t p = 0; p < patchCount; ++p) patchFirst[p + 1] += patchFirst[p];
  patchTriangles.resize(patchOfTriangle.size());
  std::vector<uint32_t> fill(patchFirst.begin(), patchFirst.end() - 1);
  for (uint32_t t = 0; t < patchOfTriangle.size(); ++t) patchTriangles[fill[patchOfTriangle[t]]++] = t;
  patchOfTriangleBuffer =
      createBufferWithData<uint32_t>(ctx, patchOfTriangle, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "patch of triangle");
  VkDeviceSize flagBytes = std::max<VkDeviceSize>(VkDeviceSize(patchCount) * 4, 4);
  flags = createBuffer(ctx, flagBytes,
                       VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT |
                           VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                       MemoryUsage::GpuOnly, "patch flags");
  flagsReadback =
      createBuffer(ctx, flagBytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::Readback, "patch flags readback");
  frame =
      createBuffer(ctx, sizeof(sio::FrameData), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::Upload, "atlas frame");

  // The atlas, zeroed, kept in GENERAL (storage writes, copies out).
  atlas = createImage2D(ctx, config.atlasSide, config.atlasSide, kAtlasFormat,
                        VK_IMAGE_USAGE_STORAGE_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT,
                        "atlas");
  ctx.submitAndWait([&](VkCommandBuffer cmd) {
    cmdImageBarrier(cmd, {atlas.handle(), VK_PIPELINE_STAGE_2_NONE, 0, VK_PIPELINE_STAGE_2_CLEAR_BIT,
                          VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_GENERAL});
    VkClearColorValue zero{};
    VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdClearColorImage(cmd, atlas.handle(), VK_IMAGE_LAYOUT_GENERAL, &zero, 1, &range);
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
  });

  VkDescriptorSetLayoutBinding bindings[] = {
      {0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, uint32_t(textures.size()),
       VK_SHADER_STAGE_FRAGMENT_BIT | VK_SHADER_STAGE_COMPUTE_BIT, nullptr},
      {1, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, 1, VK_SHADER_STAGE_COMPUTE_BIT, nullptr}};
  descriptors = createDescriptorSet(ctx, bindings);
  std::vector<VkDescriptorImageInfo> infos;
  for (const Image& img : textures) infos.push_back({sampler, img.view(), VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL});
  writeImageDescriptors(ctx, descriptors.set, 0, VK_DESCRIPTOR_TYPE_COMBINED_IMAGE_SAMPLER, infos);
  VkDescriptorImageInfo atlasInfo{VK_NULL_HANDLE, atlas.view(), VK_IMAGE_LAYOUT_GENERAL};
  writeImageDescriptors(ctx, descriptors.set, 1, VK_DESCRIPTOR_TYPE_STORAGE_IMAGE, {&atlasInfo, 1});
  if (visibilityMethod == AtlasVisibilityMethod::Compute) uploadClusters(scene, merged.firstVertex, merged.vertices);
  return Ok{};
}

void AtlasShading::Impl::createPipelines() {
  visibilityLayout = createPipelineLayout(ctx, {descriptors.layout.get()}, sizeof(sio::AtlasVisibilityPush),
                                          VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_FRAGMENT_BIT);
  GraphicsPipelineDesc d;
  d.vertexShader = "atlas_visibility.vert";
  d.layout = visibilityLayout;
  d.bindings = {{0, sizeof(sio::GpuVertex), VK_VERTEX_INPUT_RATE_VERTEX}};
  d.attributes = {{0, 0, VK_FORMAT_R32G32B32_SFLOAT, offsetof(sio::GpuVertex, position)},
                  {1, 0, VK_FORMAT_R32G32_SFLOAT, offsetof(sio::GpuVertex, uv)},
                  {2, 0, VK_FORMAT_R8G8B8A8_UNORM, offsetof(sio::GpuVertex, color)}};
  d.depthFormat = kAtlasDepthFormat;
  d.depthCompare = VK_COMPARE_OP_GREATER; // reverse-Z
  if (visibilityMethod == AtlasVisibilityMethod::Compute) createComputeVisibilityPipelines();
  prepassOpaque = createGraphicsPipeline(ctx, d);
  d.fragmentShader = "atlas_visibility_mask.frag";
  prepassMask = createGraphicsPipeline(ctx, d);
  // Marking: the prepass's own surfaces (EQUAL: a MASK texel cut away left something farther
  // there), and BLEND surfaces not behind them.
  d.fragmentShader = "atlas_visibility_mark.frag";
  d.depthWrite = false;
  d.depthCompare = VK_COMPARE_OP_EQUAL;
  markEqual = createGraphicsPipeline(ctx, d);
  d.depthCompare = VK_COMPARE_OP_GREATER_OR_EQUAL;
  markInFront = createGraphicsPipeline(ctx, d);

  uint32_t pushBytes =
      uint32_t(std::max({sizeof(sio::AtlasShadePush), sizeof(sio::AtlasColourPush), sizeof(sio::AtlasYuvPush)}));
  computeLayout = createPipelineLayout(ctx, {descriptors.layout.get()}, pushBytes, VK_SHADER_STAGE_COMPUTE_BIT);
  std::vector<uint32_t> spec = materialMapSpecialization(sceneMaterials, textures.size());
  shadePipeline = createComputePipeline(ctx, "atlas_shade.comp", computeLayout, spec);
  colourPipeline = createComputePipeline(ctx, "atlas_colour.comp", computeLayout, spec);
  clearPipeline = createComputePipeline(ctx, "atlas_clear.comp", computeLayout);
  yuvPipeline = createComputePipeline(ctx, "atlas_yuv.comp", computeLayout);
}

void AtlasShading::Impl::writeFrame(const AtlasLighting& lighting, glm::vec3 eye) {
  sio::FrameData fd{};
  fd.camera.eye = glm::vec4(eye, 1.0f);
  fd.lightDir = glm::vec4(glm::normalize(lighting.lightDirection), lighting.lightIntensity);
  fd.skyAmbient = glm::vec4(lighting.skyAmbient, 0.0f);
  fd.groundAmbient = glm::vec4(lighting.groundAmbient, 0.0f);
  fd.lightAddress = lights.address();
  fd.lightCount = lightCount;
  std::memcpy(frame.mapped(), &fd, sizeof(fd));
}

AtlasShading::AtlasShading(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
AtlasShading::~AtlasShading() = default;

Result<std::unique_ptr<AtlasShading>> AtlasShading::create(Context& context, const Scene& scene,
                                                           std::vector<uint32_t> patchOfTriangle,
                                                           const AtlasShadingConfig& config) {
  if (config.atlasSide < kSuperblockSide || config.atlasSide > kMaxRenderDimension ||
      config.atlasSide % kSuperblockSide != 0)
    return Error{fmt::format("atlas side {} is not a multiple of {} in {}..{}", config.atlasSide, kSuperblockSide,
                             kSuperblockSide, kMaxRenderDimension)};
  if (config.maxPatches == 0) return Error{"atlas shading: maxPatches must be at least 1"};
  bool computeSupported = Impl::computeVisibilitySupported(context);
  if (config.visibility == AtlasVisibilityMethod::Compute && !computeSupported)
    return Error{"atlas shading: compute visibility needs 64-bit buffer and shared atomics, which this device lacks"};
  auto impl = std::make_unique<Impl>(context);
  impl->config = config;
  impl->visibilityMethod = config.visibility == AtlasVisibilityMethod::Hardware || !computeSupported
                               ? AtlasVisibilityMethod::Hardware
                               : AtlasVisibilityMethod::Compute;
  impl->patchOfTriangle = std::move(patchOfTriangle);
  if (Status st = impl->upload(scene); !st) return st.error();
  impl->createPipelines();
  return std::unique_ptr<AtlasShading>(new AtlasShading(std::move(impl)));
}

uint32_t AtlasShading::patchCount() const { return impl_->patchCount; }
uint32_t AtlasShading::atlasSide() const { return impl_->config.atlasSide; }
AtlasVisibilityMethod AtlasShading::visibilityMethod() const { return impl_->visibilityMethod; }

namespace {

Status checkPatch(const sio::GpuAtlasPatch& p, size_t i, uint32_t vertexCount, size_t instanceCount,
                  size_t materialCount, uint32_t side) {
  if (p.triangleCount < 1 || p.triangleCount > MIRAGE_ATLAS_MAX_PATCH_TRIANGLES)
    return Error{fmt::format("atlas patch {}: {} triangles (1..3)", i, p.triangleCount)};
  if (p.blockLog2 < MIRAGE_ATLAS_MIN_BLOCK_LOG2 || p.blockLog2 > MIRAGE_ATLAS_MAX_BLOCK_LOG2)
    return Error{fmt::format("atlas patch {}: block log2 {} is outside {}..{}", i, p.blockLog2,
                             MIRAGE_ATLAS_MIN_BLOCK_LOG2, MIRAGE_ATLAS_MAX_BLOCK_LOG2)};
  uint32_t w = sio::atlasBlockWidth(p.triangleCount, p.blockLog2), h = 1u << p.blockLog2;
  if (uint64_t(p.blockX) + w > side || uint64_t(p.blockY) + h > side)
    return Error{fmt::format("atlas patch {}: its {}x{} block at ({}, {}) leaves the {}-texel atlas", i, w, h, p.blockX,
                             p.blockY, side)};
  for (uint32_t v : p.vertices)
    if (v >= vertexCount)
      return Error{fmt::format("atlas patch {}: vertex {} is outside the scene's {} vertices", i, v, vertexCount)};
  if (p.instance >= instanceCount)
    return Error{fmt::format("atlas patch {}: instance {} is outside the scene's {}", i, p.instance, instanceCount)};
  if (p.material >= materialCount)
    return Error{fmt::format("atlas patch {}: material {} is outside the scene's {}", i, p.material, materialCount)};
  return Ok{};
}

// Workgroups for `count` groups in x, spilling into y past the 65535 guaranteed per dimension.
VkExtent2D groupGrid(uint32_t count) {
  uint32_t x = std::min<uint32_t>(count, 65535u);
  return {x, (count + x - 1) / x};
}

} // namespace

Status AtlasShading::shade(std::span<const sio::GpuAtlasPatch> patches, const AtlasLighting& lighting, glm::vec3 eye) {
  Impl& d = *impl_;
  if (patches.size() > d.config.maxPatches)
    return Error{fmt::format("{} atlas patches exceed the {} shaded per call", patches.size(), d.config.maxPatches)};
  std::vector<sio::AtlasTile> tiles;
  for (size_t i = 0; i < patches.size(); ++i) {
    const sio::GpuAtlasPatch& p = patches[i];
    if (Status st = checkPatch(p, i, d.vertexCount, d.instances.size(), d.sceneMaterials.size(), d.config.atlasSide);
        !st)
      return st;
    uint32_t tilesX = (sio::atlasBlockWidth(p.triangleCount, p.blockLog2) + MIRAGE_ATLAS_TILE - 1) / MIRAGE_ATLAS_TILE;
    uint32_t tilesY = ((1u << p.blockLog2) + MIRAGE_ATLAS_TILE - 1) / MIRAGE_ATLAS_TILE;
    for (uint32_t y = 0; y < tilesY; ++y)
      for (uint32_t x = 0; x < tilesX; ++x) tiles.push_back({uint32_t(i), x | y << 16});
  }
  if (tiles.empty()) return Ok{};
  d.patchBuffer.ensure(d.ctx, patches.size_bytes(), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::Upload,
                       "atlas patches");
  d.tileBuffer.ensure(d.ctx, tiles.size() * sizeof(sio::AtlasTile), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                      MemoryUsage::Upload, "atlas tiles");
  std::memcpy(d.patchBuffer.buffer.mapped(), patches.data(), patches.size_bytes());
  std::memcpy(d.tileBuffer.buffer.mapped(), tiles.data(), tiles.size() * sizeof(sio::AtlasTile));
  d.writeFrame(lighting, eye);

  sio::AtlasShadePush push{};
  push.frameAddress = d.frame.address();
  push.vertexAddress = d.vertices.address();
  push.instanceAddress = d.instanceBuffer.address();
  push.materialAddress = d.materials.address();
  push.patchAddress = d.patchBuffer.buffer.address();
  push.tileAddress = d.tileBuffer.buffer.address();
  push.tileCount = uint32_t(tiles.size());
  VkExtent2D grid = groupGrid(push.tileCount);
  d.submitTimed("shade", [&](VkCommandBuffer cmd) {
    // Earlier reads of the atlas (copies out) and writes finish before these writes.
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                     VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.shadePipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.computeLayout, 0, 1, &d.descriptors.set, 0, nullptr);
    vkCmdPushConstants(cmd, d.computeLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
    vkCmdDispatch(cmd, grid.width, grid.height, 1);
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
  });
  return Ok{};
}

void AtlasShading::clearAtlas() {
  Impl& d = *impl_;
  d.submitTimed("clear", [&](VkCommandBuffer cmd) {
    // A compute store (atlas_clear.comp): on an H200, vkCmdClearColorImage of the 2048 atlas took
    // 1.06-1.24 ms a frame against 0.08-0.09 ms.
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                     VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                     VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.clearPipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.computeLayout, 0, 1, &d.descriptors.set, 0, nullptr);
    vkCmdDispatch(cmd, d.config.atlasSide / 8, d.config.atlasSide / 8, 1);
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
  });
}

std::vector<gpu::PassTime> AtlasShading::takePassTimes() { return std::exchange(impl_->passTimes, {}); }

ImageRGBA8 AtlasShading::readAtlas() {
  const uint32_t side = impl_->config.atlasSide;
  return std::move(*readAtlasRegion(0, 0, side, side)); // the whole atlas: never out of range
}

AtlasYuvImage AtlasShading::createYuvImage(bool stackedAlpha) {
  Impl& d = *impl_;
  AtlasYuvImage image;
  image.side = d.config.atlasSide;
  image.stackedAlpha = stackedAlpha;
  image.buffer = createBuffer(d.ctx, shaderio::atlasYuvBytes(image.side, stackedAlpha),
                              VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::Readback, "atlas yuv");
  return image;
}

Status AtlasShading::convertAtlasYuv(AtlasYuvImage& image) {
  Impl& d = *impl_;
  const uint32_t side = d.config.atlasSide;
  if (image.side != side || !image.buffer || image.buffer.size() < image.i420().size())
    return Error{fmt::format("a YUV image of a {}-texel atlas given to convert the {}-texel atlas", image.side, side)};
  // The pass writes device memory and a copy moves the planes to the host: on an H100 the same
  // pass writing host memory directly took 2.6 ms for a stacked 2048 atlas (12 MB).
  const VkDeviceSize bytes = image.i420().size();
  d.yuvScratch.ensure(d.ctx, bytes, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                      MemoryUsage::GpuOnly, "atlas yuv scratch");
  sio::AtlasYuvPush push{d.yuvScratch.buffer.address(), side, image.stackedAlpha ? 1u : 0u};
  // A thread per MIRAGE_ATLAS_YUV_RUN x 2 texels; the side is a multiple of the superblock (128).
  const uint32_t groupsX = side / (MIRAGE_ATLAS_YUV_RUN * MIRAGE_ATLAS_YUV_GROUP);
  const uint32_t groupsY = side / (2 * MIRAGE_ATLAS_YUV_GROUP);
  d.submitTimed("yuv", [&](VkCommandBuffer cmd) {
    // barriers: the atlas's last clear or shading finished before it is read; the host reads after.
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.yuvPipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.computeLayout, 0, 1, &d.descriptors.set, 0, nullptr);
    vkCmdPushConstants(cmd, d.computeLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
    vkCmdDispatch(cmd, groupsX, groupsY, 1);
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT);
    uint32_t copy = d.timer.cmdBegin(cmd, "yuv.copy");
    VkBufferCopy region{0, 0, bytes};
    vkCmdCopyBuffer(cmd, d.yuvScratch.buffer.handle(), image.buffer.handle(), 1, &region);
    d.timer.cmdEnd(cmd, copy);
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                     VK_ACCESS_2_HOST_READ_BIT);
  });
  return Ok{};
}

Status AtlasShading::writeAtlasRegions(std::span<const AtlasRegionWrite> writes) {
  Impl& d = *impl_;
  const uint32_t side = d.config.atlasSide;
  VkDeviceSize bytes = 0;
  std::vector<VkBufferImageCopy> regions;
  for (const AtlasRegionWrite& w : writes) {
    if (!w.image || w.image->width == 0 || w.image->height == 0 || uint64_t(w.x) + w.image->width > side ||
        uint64_t(w.y) + w.image->height > side ||
        w.image->pixels.size() != size_t(w.image->width) * w.image->height * 4)
      return Error{fmt::format("atlas write at ({}, {}) is empty or leaves the {}-texel atlas", w.x, w.y, side)};
    VkBufferImageCopy r{};
    r.bufferOffset = bytes;
    r.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    r.imageOffset = {int32_t(w.x), int32_t(w.y), 0};
    r.imageExtent = {w.image->width, w.image->height, 1};
    regions.push_back(r);
    bytes += w.image->pixels.size();
  }
  if (regions.empty()) return Ok{};
  d.uploadBuffer.ensure(d.ctx, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUsage::Upload, "atlas uploads");
  for (size_t i = 0; i < writes.size(); ++i)
    std::memcpy(d.uploadBuffer.buffer.mapped() + regions[i].bufferOffset, writes[i].image->pixels.data(),
                writes[i].image->pixels.size());
  d.submitTimed("upload", [&](VkCommandBuffer cmd) {
    cmdImageBarrier(cmd,
                    {d.atlas.handle(), VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                     VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT, VK_PIPELINE_STAGE_2_COPY_BIT,
                     VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_GENERAL, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL});
    vkCmdCopyBufferToImage(cmd, d.uploadBuffer.buffer.handle(), d.atlas.handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                           uint32_t(regions.size()), regions.data());
    cmdImageBarrier(cmd,
                    {d.atlas.handle(), VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT,
                     VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_GENERAL});
  });
  return Ok{};
}

Result<ImageRGBA8> AtlasShading::readAtlasRegion(uint32_t x, uint32_t y, uint32_t width, uint32_t height) {
  Impl& d = *impl_;
  const uint32_t side = d.config.atlasSide;
  if (width == 0 || height == 0 || uint64_t(x) + width > side || uint64_t(y) + height > side)
    return Error{
        fmt::format("atlas region {}x{} at ({}, {}) is empty or leaves the {}-texel atlas", width, height, x, y, side)};
  VkDeviceSize bytes = VkDeviceSize(width) * height * 4;
  d.regionBuffer.ensure(d.ctx, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::Readback, "atlas region");
  d.ctx.submitAndWait([&](VkCommandBuffer cmd) {
    cmdImageBarrier(cmd, {d.atlas.handle(), VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT,
                          VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_GENERAL,
                          VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL});
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageOffset = {int32_t(x), int32_t(y), 0};
    region.imageExtent = {width, height, 1};
    vkCmdCopyImageToBuffer(cmd, d.atlas.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, d.regionBuffer.buffer.handle(),
                           1, &region);
    cmdImageBarrier(cmd,
                    {d.atlas.handle(), VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT,
                     VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT,
                     VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, VK_IMAGE_LAYOUT_GENERAL});
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                     VK_ACCESS_2_HOST_READ_BIT);
  });
  ImageRGBA8 out{width, height, std::vector<uint8_t>(bytes)};
  std::memcpy(out.pixels.data(), d.regionBuffer.buffer.mapped(), bytes);
  return out;
}

namespace {

// Barycentrics of p's projection onto the plane of (a, b, c); nullopt for a degenerate triangle.
std::optional<glm::vec3> planeBarycentrics(glm::vec3 p, glm::vec3 a, glm::vec3 b, glm::vec3 c) {
  glm::vec3 e1 = b - a, e2 = c - a, q = p - a;
  float d11 = glm::dot(e1, e1), d12 = glm::dot(e1, e2), d22 = glm::dot(e2, e2);
  float det = d11 * d22 - d12 * d12;
  if (!(det > 1e-20f * d11 * d22)) return std::nullopt;
  float q1 = glm::dot(q, e1), q2 = glm::dot(q, e2);
  float v = (d22 * q1 - d12 * q2) / det, w = (d11 * q2 - d12 * q1) / det;
  return glm::vec3(1.0f - v - w, v, w);
}

} // namespace

Result<std::vector<glm::u8vec4>> AtlasShading::shadeColours(std::span<const uint32_t> patchIds,
                                                            const AtlasLighting& lighting, glm::vec3 eye) {
  Impl& d = *impl_;
  std::vector<sio::AtlasColourSample> samples;
  samples.reserve(patchIds.size());
  for (uint32_t id : patchIds) {
    if (id >= d.patchCount || d.patchFirst[id] == d.patchFirst[id + 1])
      return Error{fmt::format("colour-only patch {} has no triangles ({} patch ids)", id, d.patchCount)};
    struct Corner {
      std::array<uint32_t, 3> v;
      std::array<glm::vec3, 3> p;
      uint32_t instance;
    };
    std::vector<Corner> tris;
    glm::vec3 weighted(0.0f), plain(0.0f);
    float area = 0.0f;
    for (uint32_t k = d.patchFirst[id]; k < d.patchFirst[id + 1]; ++k) {
      uint32_t t = d.patchTriangles[k];
      uint32_t inst = uint32_t(std::upper_bound(d.triangleOffsets.begin(), d.triangleOffsets.end(), t) -
                               d.triangleOffsets.begin()) -
                      1;
      const AtlasMeshRange& m = d.meshes[d.instances[inst].mesh];
      Corner c{{}, {}, inst};
      for (uint32_t j = 0; j < 3; ++j) {
        c.v[j] = m.firstVertex + d.meshIndices[m.firstIndex + (t - d.triangleOffsets[inst]) * 3 + j];
        c.p[j] = glm::vec3(d.instances[inst].transform * glm::vec4(d.positions[c.v[j]], 1.0f));
      }
      float a = 0.5f * glm::length(glm::cross(c.p[1] - c.p[0], c.p[2] - c.p[0]));
      glm::vec3 centroid = (c.p[0] + c.p[1] + c.p[2]) / 3.0f;
      weighted += a * centroid;
      plain += centroid;
      area += a;
      tris.push_back(c);
    }
    glm::vec3 centroid = area > 0.0f ? weighted / area : plain / float(tris.size());
    // The triangle the centroid lies most inside of (largest smallest barycentric).
    size_t best = 0;
    glm::vec3 bestBary(1.0f / 3.0f);
    float bestScore = -std::numeric_limits<float>::infinity();
    for (size_t k = 0; k < tris.size(); ++k) {
      auto b = planeBarycentrics(centroid, tris[k].p[0], tris[k].p[1], tris[k].p[2]);
      if (!b) continue;
      float score = std::min({b->x, b->y, b->z});
      if (score > bestScore) bestScore = score, best = k, bestBary = *b;
    }
    const Corner& c = tris[best];
    samples.push_back(
        {{c.v[0], c.v[1], c.v[2]}, c.instance, d.instanceMaterial(c.instance), bestBary.y, bestBary.z, 0});
  }
  if (samples.empty()) return std::vector<glm::u8vec4>{};
  if (samples.size() > size_t(65535) * MIRAGE_ATLAS_COLOUR_GROUP)
    return Error{fmt::format("{} colour-only patches exceed one dispatch", samples.size())};
  d.sampleBuffer.ensure(d.ctx, samples.size() * sizeof(sio::AtlasColourSample), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                        MemoryUsage::Upload, "atlas colour samples");
  d.colourBuffer.ensure(d.ctx, samples.size() * 4, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, MemoryUsage::Readback,
                        "atlas colours");
  std::memcpy(d.sampleBuffer.buffer.mapped(), samples.data(), samples.size() * sizeof(sio::AtlasColourSample));
  d.writeFrame(lighting, eye);

  sio::AtlasColourPush push{};
  push.frameAddress = d.frame.address();
  push.vertexAddress = d.vertices.address();
  push.instanceAddress = d.instanceBuffer.address();
  push.materialAddress = d.materials.address();
  push.sampleAddress = d.sampleBuffer.buffer.address();
  push.outputAddress = d.colourBuffer.buffer.address();
  push.count = uint32_t(samples.size());
  d.submitTimed("colours", [&](VkCommandBuffer cmd) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.colourPipeline);
    vkCmdBindDescriptorSets(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, d.computeLayout, 0, 1, &d.descriptors.set, 0, nullptr);
    vkCmdPushConstants(cmd, d.computeLayout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
    vkCmdDispatch(cmd, (push.count + MIRAGE_ATLAS_COLOUR_GROUP - 1) / MIRAGE_ATLAS_COLOUR_GROUP, 1, 1);
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                     VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
  });
  std::vector<glm::u8vec4> out(samples.size());
  std::memcpy(out.data(), d.colourBuffer.buffer.mapped(), out.size() * 4);
  return out;
}

} // namespace mirage::render
