#include "mirage/surfels/gpu_sampler.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <map>

#include <fmt/format.h>

#include "mirage/core/named_enum.h"
#include "mirage/gpu/commands.h"
#include "mirage/gpu/pipeline.h"
#include "mirage/gpu/radix_sort.h"

namespace mirage::surfels {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

namespace {

constexpr uint32_t kMaxGroups = gpu::kMaxDispatchGroups;
constexpr uint32_t kMaxTilesPerSide = 64;

uint32_t nextPow2(uint32_t v) {
  uint32_t p = 1;
  while (p < v) p <<= 1;
  return p;
}

uint32_t groups1D(uint64_t items) { return uint32_t(std::clamp<uint64_t>((items + 255) / 256, 1, 4096)); }

// Shader stages that read or write the sampler's buffers for each splatter.
VkPipelineStageFlags2 splatStages(DiscRaster raster) {
  switch (raster) {
  case DiscRaster::Mesh:
  case DiscRaster::MeshDepth: // its attachments have their own image barriers (cmdDepthImageBarriers)
    return VK_PIPELINE_STAGE_2_MESH_SHADER_BIT_EXT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
  case DiscRaster::Geometry:
    return VK_PIPELINE_STAGE_2_GEOMETRY_SHADER_BIT | VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT;
  case DiscRaster::Compute:
    break;
  }
  return 0;
}

VkShaderStageFlags splatPushStages(DiscRaster raster) {
  switch (raster) {
  case DiscRaster::Mesh:
  case DiscRaster::MeshDepth:
    return VK_SHADER_STAGE_MESH_BIT_EXT | VK_SHADER_STAGE_FRAGMENT_BIT;
  case DiscRaster::Geometry:
    return VK_SHADER_STAGE_VERTEX_BIT | VK_SHADER_STAGE_GEOMETRY_BIT | VK_SHADER_STAGE_FRAGMENT_BIT;
  case DiscRaster::Compute:
    break;
  }
  return VK_SHADER_STAGE_COMPUTE_BIT;
}

struct Sampler {
  Context& ctx;
  const GpuGBuffer& gb;
  DiscRaster raster = DiscRaster::Compute;
  Unique<VkPipelineLayout> layout, rasterLayout;
  Unique<VkPipeline> splat, farthest, candidates, validate, append;
  Unique<VkPipeline> depthSplat, depthCells; // mesh-depth: the depth-test Voronoi and its conversion to cells
  Image depthImage, idImage;                 // mesh-depth: one layer per view, kept across rounds
  Buffer depthCopy, idCopy;
  uint32_t depthShift = 0;
  Buffer globals, cells, owners, samples, radii, cellMax, candidateKeys, counters, hostCounters, views;
  GpuTimer timer;
  std::map<std::string, double> stageMs;
  std::vector<std::string> stageOrder;

  Sampler(Context& c, const GpuGBuffer& g, DiscRaster r) : ctx(c), gb(g), raster(r), timer(c, 32) {}

  void cmdBarrier(VkCommandBuffer cmd) {
    VkPipelineStageFlags2 stages =
        VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT | splatStages(raster);
    cmdMemoryBarrier(cmd, stages, VK_ACCESS_2_SHADER_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT, stages,
                     VK_ACCESS_2_SHADER_READ_BIT | VK_ACCESS_2_SHADER_WRITE_BIT | VK_ACCESS_2_TRANSFER_READ_BIT |
                         VK_ACCESS_2_TRANSFER_WRITE_BIT);
  }
  void cmdDispatch(VkCommandBuffer cmd, VkPipeline pipeline, const sio::SurfelSamplerPush& push, uint32_t x,
                   uint32_t y = 1, uint32_t z = 1) {
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, pipeline);
    vkCmdPushConstants(cmd, layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
    vkCmdDispatch(cmd, x, y, z);
  }
  sio::SurfelSamplerPush basePush() const {
    sio::SurfelSamplerPush p{};
    p.globals = globals.address();
    return p;
  }
  // Disc splats of `count` items from `first`, in chunks of the largest y dimension; `radius` bounds
  // every item's radius (<= 0: whole views).
  // barriers: the positions and the item list are written; the caller adds a barrier after.
  void cmdSplat(VkCommandBuffer cmd, uint32_t mode, uint32_t first, uint32_t count, float radius) {
    if (raster == DiscRaster::MeshDepth && mode == 0) return cmdDepthVoronoi(cmd, first, count, radius);
    if (raster != DiscRaster::Compute) return cmdRasterSplat(cmd, mode, first, count, radius);
    uint32_t res = gb.texels.resolution;
    uint32_t side = res;
    if (radius > 0.0f)
      side = uint32_t(std::min<double>(res, 2.0 * (std::ceil(radius / gb.texels.texelSize) + 2.0) + 1.0));
    sio::SurfelSamplerPush p = basePush();
    p.mode = mode;
    p.radius = radius;
    p.tilesPerSide = std::min((side + 7) / 8, kMaxTilesPerSide);
    p.tileSpan = ((side + p.tilesPerSide - 1) / p.tilesPerSide + 7) / 8 * 8;
    for (uint32_t done = 0; done < count; done += kMaxGroups) {
      p.first = first + done;
      p.count = std::min(kMaxGroups, count - done);
      cmdDispatch(cmd, splat, p, p.tilesPerSide * p.tilesPerSide, p.count, gb.texels.viewCount);
    }
  }
  // The same splat through the raster pipeline: one quad per (item, view) into a res × res
  // framebuffer without attachments; the fragment shader applies the atomic.
  void cmdRasterSplat(VkCommandBuffer cmd, uint32_t mode, uint32_t first, uint32_t count, float radius) {
    uint32_t res = gb.texels.resolution;
    VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
    ri.renderArea = {{0, 0}, {res, res}};
    ri.layerCount = 1;
    vkCmdBeginRendering(cmd, &ri);
    cmdRasterDraws(cmd, splat, mode, first, count, radius);
    vkCmdEndRendering(cmd);
  }
  // Voronoi by the depth test: the quads into their view's layer of the kept depth/id images, then
  // both images copied out and converted into `cells` for the farthest pass.
  // barriers: the images are in attachment layouts (set up by the first submit, restored here).
  void cmdDepthVoronoi(VkCommandBuffer cmd, uint32_t first, uint32_t count, float radius) {
    uint32_t res = gb.texels.resolution, viewCount = gb.texels.viewCount;
    VkRenderingAttachmentInfo color{VK_STRUCTURE_TYPE_RENDERING_ATTACHMENT_INFO};
    color.imageView = idImage.view();
    color.imageLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    color.loadOp = VK_ATTACHMENT_LOAD_OP_LOAD;
    color.storeOp = VK_ATTACHMENT_STORE_OP_STORE;
    VkRenderingAttachmentInfo depth = color;
    depth.imageView = depthImage.view();
    depth.imageLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
    ri.renderArea = {{0, 0}, {res, res}};
    ri.layerCount = viewCount;
    ri.colorAttachmentCount = 1;
    ri.pColorAttachments = &color;
    ri.pDepthAttachment = &depth;
    vkCmdBeginRendering(cmd, &ri);
    cmdRasterDraws(cmd, depthSplat, 0, first, count, radius);
    vkCmdEndRendering(cmd);
    cmdDepthImageBarriers(cmd, false);
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, viewCount};
    region.imageExtent = {res, res, 1};
    vkCmdCopyImageToBuffer(cmd, idImage.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, idCopy.handle(), 1, &region);
    region.imageSubresource.aspectMask = VK_IMAGE_ASPECT_DEPTH_BIT;
    vkCmdCopyImageToBuffer(cmd, depthImage.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, depthCopy.handle(), 1,
                           &region);
    cmdDepthImageBarriers(cmd, true);
    cmdBarrier(cmd);
    sio::SurfelSamplerPush p = basePush();
    p.depthShift = depthShift;
    cmdDispatch(cmd, depthCells, p, groups1D(uint64_t(viewCount) * res * res));
  }
  // The depth/id images from attachment to copy-source layouts (toAttachment false) or back.
  void cmdDepthImageBarriers(VkCommandBuffer cmd, bool toAttachment) {
    ImageBarrier b[2];
    b[0].image = idImage.handle();
    b[0].srcStage = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
    b[0].srcAccess = VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT;
    b[0].oldLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    b[1].image = depthImage.handle();
    b[1].srcStage = VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
    b[1].srcAccess = VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    b[1].oldLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    b[1].aspect = VK_IMAGE_ASPECT_DEPTH_BIT;
    for (ImageBarrier& x : b) {
      x.dstStage = VK_PIPELINE_STAGE_2_COPY_BIT;
      x.dstAccess = VK_ACCESS_2_TRANSFER_READ_BIT;
      x.newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL;
      if (toAttachment) {
        std::swap(x.srcStage, x.dstStage);
        std::swap(x.oldLayout, x.newLayout);
        x.srcAccess = VK_ACCESS_2_TRANSFER_READ_BIT;
        x.dstAccess = &x == &b[0] ? VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT
                                  : VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT |
                                        VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
      }
    }
    cmdImageBarriers(cmd, b);
  }
  // The quads of `count` items from `first` with `pipeline`, inside a begun rendering.
  void cmdRasterDraws(VkCommandBuffer cmd, VkPipeline pipeline, uint32_t mode, uint32_t first, uint32_t count,
                      float radius) {
    uint32_t res = gb.texels.resolution, viewCount = gb.texels.viewCount;
    cmdSetFullViewport(cmd, res, res);
    vkCmdSetCullMode(cmd, VK_CULL_MODE_NONE);
    vkCmdSetFrontFace(cmd, VK_FRONT_FACE_COUNTER_CLOCKWISE);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, pipeline);
    sio::SurfelSamplerPush p = basePush();
    p.depthShift = depthShift;
    p.mode = mode;
    p.radius = radius;
    // Mesh draws: 32 (item, view) pairs per work group, at most kMaxGroups groups per draw.
    uint32_t perDraw = std::max(1u, kMaxGroups * 32 / viewCount);
    for (uint32_t done = 0; done < count; done += perDraw) {
      p.first = first + done;
      p.count = std::min(perDraw, count - done);
      vkCmdPushConstants(cmd, rasterLayout, splatPushStages(raster), 0, sizeof(p), &p);
      uint32_t pairs = p.count * viewCount;
      if (raster == DiscRaster::Geometry)
        vkCmdDraw(cmd, pairs, 1, 0, 0);
      else
        vkCmdDrawMeshTasksEXT(cmd, (pairs + 31) / 32, 1, 1);
    }
  }
  uint32_t cmdBegin(VkCommandBuffer cmd, const char* name) {
    if (!stageMs.count(name)) stageOrder.push_back(name), stageMs[name] = 0.0;
    return timer.cmdBegin(cmd, name);
  }
  void collectTimes() {
    for (const PassTime& t : timer.read()) stageMs[t.name] += t.milliseconds;
  }
  sio::SurfelSamplerCounters readCounters() const {
    sio::SurfelSamplerCounters c;
    std::memcpy(&c, hostCounters.mapped(), sizeof(c));
    return c;
  }
  void cmdCopyCounters(VkCommandBuffer cmd) {
    cmdBarrier(cmd);
    VkBufferCopy region{0, 0, sizeof(sio::SurfelSamplerCounters)};
    vkCmdCopyBuffer(cmd, counters.handle(), hostCounters.handle(), 1, &region);
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                     VK_ACCESS_2_HOST_READ_BIT);
  }
};

} // namespace

const char* toString(DiscRaster raster) {
  switch (raster) {
  case DiscRaster::Compute:
    return "compute";
  case DiscRaster::Mesh:
    return "mesh";
  case DiscRaster::Geometry:
    return "geometry";
  case DiscRaster::MeshDepth:
    return "mesh-depth";
  }
  return "?";
}

Result<DiscRaster> parseDiscRaster(std::string_view text) {
  return parseNamed(text, "--disc-raster",
                    {DiscRaster::Compute, DiscRaster::Mesh, DiscRaster::Geometry, DiscRaster::MeshDepth});
}

std::string discRasterUnsupported(const Context& ctx, DiscRaster raster, uint32_t views) {
  const DeviceCapabilities& c = ctx.caps();
  const VkPhysicalDeviceLimits& limits = ctx.properties().limits;
  std::string missing;
  if ((raster == DiscRaster::Mesh || raster == DiscRaster::MeshDepth) && !c.meshShader)
    missing = "mesh shaders (VK_EXT_mesh_shader)";
  if (raster == DiscRaster::MeshDepth) {
    VkFormatProperties depth, id;
    vkGetPhysicalDeviceFormatProperties(ctx.physicalDevice(), VK_FORMAT_D32_SFLOAT, &depth);
    vkGetPhysicalDeviceFormatProperties(ctx.physicalDevice(), VK_FORMAT_R32_UINT, &id);
    if (!(depth.optimalTilingFeatures & VK_FORMAT_FEATURE_DEPTH_STENCIL_ATTACHMENT_BIT) ||
        !(id.optimalTilingFeatures & VK_FORMAT_FEATURE_COLOR_ATTACHMENT_BIT))
      missing += std::string(missing.empty() ? "" : " and ") + "D32_SFLOAT depth and R32_UINT colour attachments";
    uint32_t maxLayers = std::min(limits.maxFramebufferLayers, limits.maxImageArrayLayers);
    if (views > maxLayers)
      missing +=
          std::string(missing.empty() ? "" : " and ") + fmt::format("{} framebuffer layers (one per view)", views);
  }
  if (raster == DiscRaster::Geometry && !c.geometryShader) missing = "geometry shaders (geometryShader)";
  if (raster != DiscRaster::Compute && !c.fragmentStoresAndAtomics)
    missing += std::string(missing.empty() ? "" : " and ") + "fragment-shader atomics (fragmentStoresAndAtomics)";
  if (missing.empty()) return {};
  return fmt::format("surfels: --disc-raster {} needs {}, which {} does not have", toString(raster), missing, c.name);
}

Result<GpuSamplerResult> sampleOnGpu(Context& ctx, const GpuGBuffer& gb, const GpuSamplerConfig& config) {
  if (!ctx.caps().int64BufferAtomics)
    return Error{"surfels: the GPU sampler needs 64-bit buffer atomics (shaderBufferInt64Atomics)"};
  if (config.count == 0) return Error{"surfels: the surfel count must be at least 1"};
  if (gb.texels.size() == 0) return Error{"surfels: the G-buffer has no texels to sample"};
  // Distances from non-finite positions compare false both ways: no round would ever append a sample.
  if (!std::isfinite(gb.texels.sphereRadius))
    return Error{"surfels: the G-buffer's bounding sphere is not finite (non-finite input coordinates)"};
  for (size_t i = 0; i < gb.texels.size(); ++i) {
    glm::vec3 p = gb.texels.positions[i];
    if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
      return Error{
          fmt::format("surfels: G-buffer texel {} has a non-finite position (non-finite input coordinates)", i)};
  }
  if (std::string why = discRasterUnsupported(ctx, config.discRaster, gb.texels.viewCount); !why.empty())
    return Error{why};
  const VkPhysicalDeviceLimits& limits = ctx.properties().limits;
  if (config.discRaster != DiscRaster::Compute &&
      (gb.texels.resolution > limits.maxFramebufferWidth || gb.texels.resolution > limits.maxFramebufferHeight))
    return Error{fmt::format("surfels: --disc-raster {} renders {}² but the framebuffer limit is {}",
                             toString(config.discRaster), gb.texels.resolution, limits.maxFramebufferWidth)};
  auto start = std::chrono::steady_clock::now();
  Sampler s(ctx, gb, config.discRaster);
  const GBufferTexels& t = gb.texels;
  uint64_t texelCount = uint64_t(t.viewCount) * t.resolution * t.resolution;
  uint32_t target = uint32_t(std::min<uint64_t>(config.count, t.size()));
  // Each round adds at most one sample per existing cell and stops once `target` is reached, so the
  // sample arrays never exceed 2·target (+1 for the first round).
  uint32_t capacity = 2 * target + 2;
  uint32_t keyCapacity = nextPow2(capacity);

  VkBufferUsageFlags usage =
      VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
  s.cells = createBuffer(ctx, texelCount * 8, usage, MemoryUsage::GpuOnly, "surfel cells");
  s.owners = createBuffer(ctx, texelCount * 8, usage, MemoryUsage::GpuOnly, "surfel owners");
  s.samples = createBuffer(ctx, size_t(capacity) * 4, usage, MemoryUsage::GpuOnly, "surfel samples");
  s.radii = createBuffer(ctx, size_t(capacity) * 4, usage, MemoryUsage::GpuOnly, "surfel radii");
  s.cellMax = createBuffer(ctx, size_t(capacity) * 8, usage, MemoryUsage::GpuOnly, "surfel cell maxima");
  s.candidateKeys = createBuffer(ctx, size_t(keyCapacity) * 8, usage, MemoryUsage::GpuOnly, "surfel candidates");
  s.counters = createBuffer(ctx, sizeof(sio::SurfelSamplerCounters), usage, MemoryUsage::GpuOnly, "surfel counters");
  s.hostCounters = createBuffer(ctx, sizeof(sio::SurfelSamplerCounters), VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                MemoryUsage::Readback, "surfel counters readback");
  s.views = createBufferWithData<sio::SurfelView>(ctx, gb.views, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "surfel views");
  if (config.discRaster == DiscRaster::MeshDepth) {
    s.depthCopy = createBuffer(ctx, texelCount * 4, usage, MemoryUsage::GpuOnly, "surfel depth copy");
    s.idCopy = createBuffer(ctx, texelCount * 4, usage, MemoryUsage::GpuOnly, "surfel id copy");
    VkImageCreateInfo ci{VK_STRUCTURE_TYPE_IMAGE_CREATE_INFO};
    ci.imageType = VK_IMAGE_TYPE_2D;
    ci.extent = {t.resolution, t.resolution, 1};
    ci.mipLevels = 1;
    ci.arrayLayers = t.viewCount;
    ci.samples = VK_SAMPLE_COUNT_1_BIT;
    ci.usage = VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT;
    ci.format = VK_FORMAT_D32_SFLOAT;
    ci.usage |= VK_IMAGE_USAGE_DEPTH_STENCIL_ATTACHMENT_BIT;
    s.depthImage = createImage(ctx, ci, VK_IMAGE_ASPECT_DEPTH_BIT, "surfel Voronoi depth");
    ci.format = VK_FORMAT_R32_UINT;
    ci.usage = VK_IMAGE_USAGE_TRANSFER_SRC_BIT | VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT;
    s.idImage = createImage(ctx, ci, VK_IMAGE_ASPECT_COLOR_BIT, "surfel Voronoi ids");
    // Depth = distance · 2^-shift <= 0.5 for every distance inside the capture sphere (<= its
    // diameter), below the cleared 1.0; scaling by a power of two is exact, so the conversion back
    // gives the fragment shader's distance bit for bit.
    s.depthShift = uint32_t(int(std::ceil(std::log2(2.0 * t.sphereRadius * 1.01))) + 1);
  }
  sio::SurfelSamplerGlobals g{};
  g.positions = gb.positions.address();
  g.cells = s.cells.address();
  g.owners = s.owners.address();
  g.samples = s.samples.address();
  g.radii = s.radii.address();
  g.cellMax = s.cellMax.address();
  g.candidates = s.candidateKeys.address();
  g.counters = s.counters.address();
  g.views = s.views.address();
  g.center = glm::vec4(t.center, t.sphereRadius);
  g.resolution = t.resolution;
  g.viewCount = t.viewCount;
  g.texelCount = uint32_t(texelCount);
  g.texelSize = t.texelSize;
  if (s.depthCopy) g.depthCopy = s.depthCopy.address(), g.idCopy = s.idCopy.address();
  s.globals = createBufferWithData<sio::SurfelSamplerGlobals>(ctx, std::span(&g, 1), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                              "surfel globals");

  s.layout = createPipelineLayout(ctx, {}, sizeof(sio::SurfelSamplerPush), VK_SHADER_STAGE_COMPUTE_BIT);
  if (config.discRaster == DiscRaster::Compute) {
    s.splat = createComputePipeline(ctx, "surfel_splat.comp", s.layout);
  } else {
    s.rasterLayout = createPipelineLayout(ctx, {}, sizeof(sio::SurfelSamplerPush), splatPushStages(config.discRaster));
    GraphicsPipelineDesc d;
    if (config.discRaster == DiscRaster::Geometry) {
      d.vertexShader = "surfel_splat.vert";
      d.geometryShader = "surfel_splat.geom";
      d.topology = VK_PRIMITIVE_TOPOLOGY_POINT_LIST;
    } else {
      d.meshShader = "surfel_splat.mesh"; // mesh, and mesh-depth's conflicts
    }
    d.fragmentShader = "surfel_splat.frag";
    d.layout = s.rasterLayout;
    d.depthWrite = false; // no attachments: the fragment shader's atomics are the only output
    s.splat = createGraphicsPipeline(ctx, d);
  }
  if (config.discRaster == DiscRaster::MeshDepth) {
    GraphicsPipelineDesc d;
    d.meshShader = "surfel_splat_depth.mesh";
    d.fragmentShader = "surfel_splat_depth.frag";
    d.layout = s.rasterLayout;
    d.colorFormats = {VK_FORMAT_R32_UINT};
    d.depthFormat = VK_FORMAT_D32_SFLOAT;
    d.depthCompare = VK_COMPARE_OP_LESS; // ties keep the earlier primitive = the smaller sample index
    s.depthSplat = createGraphicsPipeline(ctx, d);
    s.depthCells = createComputePipeline(ctx, "surfel_depth_cells.comp", s.layout);
  }
  s.farthest = createComputePipeline(ctx, "surfel_farthest.comp", s.layout);
  s.candidates = createComputePipeline(ctx, "surfel_candidates.comp", s.layout);
  s.validate = createComputePipeline(ctx, "surfel_validate.comp", s.layout);
  s.append = createComputePipeline(ctx, "surfel_append.comp", s.layout);
  RadixSort sorter(ctx, keyCapacity);
  // Keys (radius bits << 32 | texel): texel indices below texelCount need only their low digits.
  RadixSortOptions sortOptions{true, digitMaskForIndexBelow(uint32_t(texelCount))};

  // Every texel starts in no cell (all ones: larger than any real key).
  // mesh-depth: depth 1 (farther than any scaled distance) and id ~0 (no sample), then attachment layouts.
  ctx.submitAndWait([&](VkCommandBuffer cmd) {
    vkCmdFillBuffer(cmd, s.cells.handle(), 0, VK_WHOLE_SIZE, ~0u);
    if (!s.depthImage) return;
    ImageBarrier b[2];
    b[0].image = s.idImage.handle();
    b[1].image = s.depthImage.handle();
    b[1].aspect = VK_IMAGE_ASPECT_DEPTH_BIT;
    for (ImageBarrier& x : b) {
      x.dstStage = VK_PIPELINE_STAGE_2_CLEAR_BIT;
      x.dstAccess = VK_ACCESS_2_TRANSFER_WRITE_BIT;
      x.newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    }
    cmdImageBarriers(cmd, b);
    VkClearColorValue noSample{};
    noSample.uint32[0] = ~0u;
    VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, VK_REMAINING_ARRAY_LAYERS};
    vkCmdClearColorImage(cmd, s.idImage.handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &noSample, 1, &range);
    VkClearDepthStencilValue far{1.0f, 0};
    range.aspectMask = VK_IMAGE_ASPECT_DEPTH_BIT;
    vkCmdClearDepthStencilImage(cmd, s.depthImage.handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &far, 1, &range);
    for (ImageBarrier& x : b) {
      x.srcStage = VK_PIPELINE_STAGE_2_CLEAR_BIT;
      x.srcAccess = VK_ACCESS_2_TRANSFER_WRITE_BIT;
      x.oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL;
    }
    b[0].dstStage = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT;
    b[0].dstAccess = VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT;
    b[0].newLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL;
    b[1].dstStage = VK_PIPELINE_STAGE_2_EARLY_FRAGMENT_TESTS_BIT | VK_PIPELINE_STAGE_2_LATE_FRAGMENT_TESTS_BIT;
    b[1].dstAccess = VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_READ_BIT | VK_ACCESS_2_DEPTH_STENCIL_ATTACHMENT_WRITE_BIT;
    b[1].newLayout = VK_IMAGE_LAYOUT_DEPTH_ATTACHMENT_OPTIMAL;
    cmdImageBarriers(cmd, b);
  });

  GpuSamplerResult result;
  uint32_t n = 0, previous = 0;
  float splatRadius = -1.0f; // the first sample's Voronoi splat covers whole views
  while (n < target) {
    // Half-round A: Voronoi splat of last round's samples, farthest texel per cell, candidates.
    // barriers: the previous submit completed (submitAndWait); each pass reads what the last wrote.
    ctx.submitAndWait([&](VkCommandBuffer cmd) {
      s.timer.cmdReset(cmd);
      if (n > previous) {
        uint32_t slot = s.cmdBegin(cmd, "voronoi");
        s.cmdSplat(cmd, 0, previous, n - previous, splatRadius);
        s.timer.cmdEnd(cmd, slot);
      }
      vkCmdFillBuffer(cmd, s.cellMax.handle(), 0, size_t(std::max(n, 1u)) * 8, 0);
      vkCmdFillBuffer(cmd, s.counters.handle(), 0, VK_WHOLE_SIZE, 0);
      s.cmdBarrier(cmd);
      uint32_t slot = s.cmdBegin(cmd, "farthest");
      sio::SurfelSamplerPush p = s.basePush();
      p.mode = n == 0 ? 1 : 0;
      s.cmdDispatch(cmd, s.farthest, p, groups1D(texelCount));
      s.timer.cmdEnd(cmd, slot);
      s.cmdBarrier(cmd);
      slot = s.cmdBegin(cmd, "candidates");
      p.count = std::max(n, 1u);
      p.threshold = n == 0 ? 0.0f : config.threshold;
      s.cmdDispatch(cmd, s.candidates, p, groups1D(p.count));
      s.timer.cmdEnd(cmd, slot);
      s.cmdCopyCounters(cmd);
    });
    s.collectTimes();
    sio::SurfelSamplerCounters c = s.readCounters();
    if (c.candidateCount == 0) break; // every texel is a sample
    float maxDistance;
    std::memcpy(&maxDistance, &c.maxDistance, 4);
    uint32_t candidates = c.candidateCount;
    uint32_t padded = nextPow2(candidates);

    // Half-round B: Poisson-disc conflicts, validation, sort by decreasing radius, append.
    ctx.submitAndWait([&](VkCommandBuffer cmd) {
      s.timer.cmdReset(cmd);
      vkCmdFillBuffer(cmd, s.owners.handle(), 0, VK_WHOLE_SIZE, 0);
      s.cmdBarrier(cmd);
      uint32_t slot = s.cmdBegin(cmd, "conflicts");
      s.cmdSplat(cmd, 1, 0, candidates, n == 0 ? -1.0f : maxDistance);
      s.timer.cmdEnd(cmd, slot);
      s.cmdBarrier(cmd);
      slot = s.cmdBegin(cmd, "sort");
      sio::SurfelSamplerPush p = s.basePush();
      p.count = candidates;
      p.padTo = config.bitonicSort ? padded : candidates;
      s.cmdDispatch(cmd, s.validate, p, groups1D(p.padTo));
      // Descending on the whole key: by radius, ties by texel, whatever order the atomics appended.
      if (config.bitonicSort)
        sorter.cmdBitonicSort(cmd, s.candidateKeys, padded, true);
      else
        sorter.cmdSort(cmd, s.candidateKeys, candidates, sortOptions);
      s.timer.cmdEnd(cmd, slot);
      s.cmdBarrier(cmd);
      slot = s.cmdBegin(cmd, "append");
      p = s.basePush();
      p.first = n;
      p.count = candidates;
      p.mode = n == 0 ? 1 : 0;
      p.radius = 2.0f * t.sphereRadius; // the first sample's radius, as in the CPU reference
      s.cmdDispatch(cmd, s.append, p, groups1D(candidates));
      s.timer.cmdEnd(cmd, slot);
      s.cmdCopyCounters(cmd);
    });
    s.collectTimes();
    uint32_t valid = s.readCounters().validCount;
    // The loop's bound: the largest candidate never conflicts with a larger one, so a sane round
    // appends at least one sample and the loop runs at most `target` rounds. A round appending none
    // would repeat forever: stop it.
    if (valid == 0)
      return Error{fmt::format("surfels: sampler round {} appended none of its {} candidates (farthest distance "
                               "{}): the G-buffer holds non-finite or degenerate positions",
                               result.rounds + 1, candidates, maxDistance)};
    if (n > 0) splatRadius = maxDistance; // texels farther than this from all samples do not exist
    previous = n;
    n += valid;
    ++result.rounds;
    if (config.progress) config.progress(std::min(n, target), target, result.rounds);
  }

  n = std::min(n, target);
  std::vector<uint8_t> ids = readbackBuffer(ctx, s.samples, size_t(std::max(n, 1u)) * 4);
  std::vector<uint8_t> radii = readbackBuffer(ctx, s.radii, size_t(std::max(n, 1u)) * 4);
  result.order.texels.resize(n);
  result.order.radii.resize(n);
  for (uint32_t i = 0; i < n; ++i) {
    uint32_t id;
    std::memcpy(&id, ids.data() + 4 * i, 4);
    std::memcpy(&result.order.radii[i], radii.data() + 4 * i, 4);
    result.order.texels[i] = t.compactIndex(id);
    if (result.order.texels[i] == UINT32_MAX)
      return Error{fmt::format("surfels: internal error: sample {} is texel {}, which saw nothing", i, id)};
    // A batch may hold radii above the previous batch's smallest: the running minimum is the radius
    // every prefix really has (all its pairwise distances are at least that large).
    if (i > 0) result.order.radii[i] = std::min(result.order.radii[i], result.order.radii[i - 1]);
  }
  for (const std::string& name : s.stageOrder) result.times.push_back({name, s.stageMs[name]});
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return result;
}

} // namespace mirage::surfels
