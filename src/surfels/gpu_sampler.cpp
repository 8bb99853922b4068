#include "mirage/surfels/gpu_sampler.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <map>

#include <fmt/format.h>

#include "mirage/gpu/commands.h"
#include "mirage/gpu/pipeline.h"
#include "mirage/gpu/radix_sort.h"

namespace mirage::surfels {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

namespace {

constexpr uint32_t kMaxGroups = 65535; // the guaranteed maxComputeWorkGroupCount per dimension
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
    uint32_t res = gb.texels.resolution, viewCount = gb.texels.viewCount;
    VkRenderingInfo ri{VK_STRUCTURE_TYPE_RENDERING_INFO};
    ri.renderArea = {{0, 0}, {res, res}};
    ri.layerCount = 1;
    vkCmdBeginRendering(cmd, &ri);
    cmdSetFullViewport(cmd, res, res);
    vkCmdSetCullMode(cmd, VK_CULL_MODE_NONE);
    vkCmdSetFrontFace(cmd, VK_FRONT_FACE_COUNTER_CLOCKWISE);
    vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_GRAPHICS, splat);
    sio::SurfelSamplerPush p = basePush();
    p.mode = mode;
    p.radius = radius;
    // Mesh draws: 32 (item, view) pairs per work group, at most kMaxGroups groups per draw.
    uint32_t perDraw = std::max(1u, kMaxGroups * 32 / viewCount);
    for (uint32_t done = 0; done < count; done += perDraw) {
      p.first = first + done;
      p.count = std::min(perDraw, count - done);
      vkCmdPushConstants(cmd, rasterLayout, splatPushStages(raster), 0, sizeof(p), &p);
      uint32_t pairs = p.count * viewCount;
      if (raster == DiscRaster::Mesh)
        vkCmdDrawMeshTasksEXT(cmd, (pairs + 31) / 32, 1, 1);
      else
        vkCmdDraw(cmd, pairs, 1, 0, 0);
    }
    vkCmdEndRendering(cmd);
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
  }
  return "?";
}

Result<DiscRaster> parseDiscRaster(std::string_view text) {
  for (DiscRaster r : {DiscRaster::Compute, DiscRaster::Mesh, DiscRaster::Geometry})
    if (text == toString(r)) return r;
  return Error{fmt::format("--disc-raster '{}': expected compute, mesh or geometry", text)};
}

std::string discRasterUnsupported(const Context& ctx, DiscRaster raster) {
  const DeviceCapabilities& c = ctx.caps();
  std::string missing;
  if (raster == DiscRaster::Mesh && !c.meshShader) missing = "mesh shaders (VK_EXT_mesh_shader)";
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
  if (std::string why = discRasterUnsupported(ctx, config.discRaster); !why.empty()) return Error{why};
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
  s.globals = createBufferWithData<sio::SurfelSamplerGlobals>(ctx, std::span(&g, 1), VK_BUFFER_USAGE_STORAGE_BUFFER_BIT,
                                                              "surfel globals");

  s.layout = createPipelineLayout(ctx, {}, sizeof(sio::SurfelSamplerPush), VK_SHADER_STAGE_COMPUTE_BIT);
  if (config.discRaster == DiscRaster::Compute) {
    s.splat = createComputePipeline(ctx, "surfel_splat.comp", s.layout);
  } else {
    s.rasterLayout = createPipelineLayout(ctx, {}, sizeof(sio::SurfelSamplerPush), splatPushStages(config.discRaster));
    GraphicsPipelineDesc d;
    if (config.discRaster == DiscRaster::Mesh) {
      d.meshShader = "surfel_splat.mesh";
    } else {
      d.vertexShader = "surfel_splat.vert";
      d.geometryShader = "surfel_splat.geom";
      d.topology = VK_PRIMITIVE_TOPOLOGY_POINT_LIST;
    }
    d.fragmentShader = "surfel_splat.frag";
    d.layout = s.rasterLayout;
    d.depthWrite = false; // no attachments: the fragment shader's atomics are the only output
    s.splat = createGraphicsPipeline(ctx, d);
  }
  s.farthest = createComputePipeline(ctx, "surfel_farthest.comp", s.layout);
  s.candidates = createComputePipeline(ctx, "surfel_candidates.comp", s.layout);
  s.validate = createComputePipeline(ctx, "surfel_validate.comp", s.layout);
  s.append = createComputePipeline(ctx, "surfel_append.comp", s.layout);
  RadixSort sorter(ctx, keyCapacity);
  // Keys (radius bits << 32 | texel): texel indices below texelCount need only their low digits.
  RadixSortOptions sortOptions{true, digitMaskForIndexBelow(uint32_t(texelCount))};

  // Every texel starts in no cell (all ones: larger than any real key).
  ctx.submitAndWait([&](VkCommandBuffer cmd) { vkCmdFillBuffer(cmd, s.cells.handle(), 0, VK_WHOLE_SIZE, ~0u); });

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
    if (n > 0) splatRadius = maxDistance; // texels farther than this from all samples do not exist
    previous = n;
    n += valid;
    ++result.rounds;
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
