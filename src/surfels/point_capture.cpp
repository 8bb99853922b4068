// GPU capture of a point cloud (a scanner's PLY) into the layered G-buffers of the mesh capture:
// a compute splat of oriented discs with a 64-bit depth test, then a resolve into the position,
// normal and colour layout the mesh capture reads back. docs/surfels.md "Point-cloud input".
#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "capture_internal.h"
#include "mirage/gpu/commands.h"
#include "mirage/gpu/pipeline.h"
#include "mirage/surfels/capture.h"
#include "mirage/surfels/point_cloud.h"

namespace mirage::surfels {

using namespace mirage::gpu;
namespace sio = mirage::shaderio;

namespace {

constexpr uint32_t kMaxGroups = gpu::kMaxDispatchGroups;

float medianOf(std::vector<float> v) {
  auto mid = v.begin() + std::ptrdiff_t(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

// The GPU's points: disc radius = the point's spacing, clamped to kMaxDiscSpacingRatio medians.
std::vector<sio::SurfelPoint> discPoints(const ScanPoints& points) {
  float maxRadius = kMaxDiscSpacingRatio * medianOf(points.spacing);
  std::vector<sio::SurfelPoint> out(points.size());
  for (size_t i = 0; i < points.size(); ++i)
    out[i] = {points.positions[i], std::min(points.spacing[i], maxRadius), points.normals[i], points.colors[i]};
  return out;
}

} // namespace

Result<GpuGBuffer> capturePointCloud(Context& ctx, const ScanPoints& points, const CaptureConfig& config) {
  const VkPhysicalDeviceLimits& limits = ctx.properties().limits;
  std::string source = "point cloud";
  if (!ctx.caps().int64BufferAtomics)
    return makeError(source, "the GPU point capture needs 64-bit buffer atomics (shaderBufferInt64Atomics)");
  if (config.resolution == 0 || config.resolution > limits.maxImageDimension2D)
    return makeError(
        source, fmt::format("G-buffer resolution {} is outside 1..{}", config.resolution, limits.maxImageDimension2D));
  if (config.views == 0 || config.views > 65535)
    return makeError(source, fmt::format("view count {} is outside 1..65535", config.views));
  if (config.layers == 0 || config.layers > 16)
    return makeError(source, fmt::format("depth-peeling layer count {} is outside 1..16", config.layers));
  // Peeling behind two-sided discs would capture the inside of every closed surface (a mesh's back
  // faces are told apart; unoriented normals cannot be).
  if (config.layers > 1 && !points.hasNormals)
    return makeError(source, "depth peeling of a point cloud needs the scan's own (oriented) normals");
  uint64_t layerTexels = uint64_t(config.views) * config.resolution * config.resolution;
  uint64_t texelCount = layerTexels * config.layers;
  if (texelCount >= (1ull << 32))
    return makeError(source, fmt::format("{} views × {} layers of {}² texels exceed 2^32 texels", config.views,
                                         config.layers, config.resolution));
  if (points.size() == 0 || points.spacing.size() != points.size()) return makeError(source, "no points to capture");

  std::vector<sio::SurfelPoint> discs = discPoints(points);
  GpuGBuffer out;
  GBufferTexels& t = out.texels;
  t.resolution = config.resolution;
  t.viewCount = config.views * config.layers;
  t.layers = config.layers;
  Bounds box;
  for (glm::vec3 p : points.positions) box.add(p);
  t.center = box.center();
  // The tightest sphere around the box centre that holds every disc, with the mesh capture's margin.
  float maxDistance = 0.0f;
  for (const sio::SurfelPoint& d : discs)
    maxDistance = std::max(maxDistance, glm::length(d.position - t.center) + d.radius);
  t.sphereRadius = maxDistance * 1.01f + 1e-6f;
  t.texelSize = 2.0f * t.sphereRadius / float(config.resolution);
  out.views = detail::captureViews(t, config.views);
  out.passes = config.layers;

  VkBufferUsageFlags storage =
      VK_BUFFER_USAGE_STORAGE_BUFFER_BIT | VK_BUFFER_USAGE_TRANSFER_DST_BIT | VK_BUFFER_USAGE_TRANSFER_SRC_BIT;
  Buffer pointBuffer =
      createBufferWithData<sio::SurfelPoint>(ctx, discs, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "surfel scan points");
  std::vector<sio::SurfelView> directionViews(out.views.begin(), out.views.begin() + config.views);
  Buffer viewBuffer =
      createBufferWithData<sio::SurfelView>(ctx, directionViews, VK_BUFFER_USAGE_STORAGE_BUFFER_BIT, "surfel views");
  Buffer keys = createBuffer(ctx, layerTexels * 8, storage, MemoryUsage::GpuOnly, "surfel point depth keys");
  out.positions = createBuffer(ctx, texelCount * 16, storage, MemoryUsage::GpuOnly, "surfel texel positions");
  Buffer normals = createBuffer(ctx, texelCount * 8, storage, MemoryUsage::GpuOnly, "surfel texel normals");
  Buffer colors = createBuffer(ctx, texelCount * 4, storage, MemoryUsage::GpuOnly, "surfel texel colours");
  const uint32_t bytesPerTexel[3] = {16, 8, 4};
  Buffer readback[3];
  for (int i = 0; i < 3; ++i)
    readback[i] = createBuffer(ctx, texelCount * bytesPerTexel[i], VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                               MemoryUsage::Readback, "surfel readback");

  Unique<VkPipelineLayout> layout =
      createPipelineLayout(ctx, {}, sizeof(sio::SurfelPointPush), VK_SHADER_STAGE_COMPUTE_BIT);
  Unique<VkPipeline> splat = createComputePipeline(ctx, "surfel_points_splat.comp", layout);
  Unique<VkPipeline> resolve = createComputePipeline(ctx, "surfel_points_resolve.comp", layout);
  sio::SurfelPointPush push{};
  push.points = pointBuffer.address();
  push.views = viewBuffer.address();
  push.depthKeys = keys.address();
  push.center = glm::vec4(t.center, t.sphereRadius);
  push.resolution = config.resolution;
  push.viewCount = config.views;
  push.pointCount = uint32_t(points.size());
  // Oriented normals (the scan's): discs facing away are left to the views they face. Estimated
  // ones have no sign: both sides are splatted and the resolve turns the normal to the viewer.
  push.cullBackFacing = points.hasNormals ? 1 : 0;
  // Overlapping discs of one surface meet a texel's ray at slightly different depths (their planes
  // tilt by the curvature, and by the noise of a real scan): a peeled layer must lie two disc
  // radii behind, not the mesh capture's quarter texel.
  push.peelEpsilon = std::max(0.25f * t.texelSize, 2.0f * medianOf(points.spacing));

  GpuTimer timer(ctx, 2 * config.layers + 1);
  // barriers: none on entry (uploads waited); on exit the readback copies are complete (submitAndWait).
  ctx.submitAndWait([&](VkCommandBuffer cmd) {
    timer.cmdReset(cmd);
    // Every pass here reads or writes what the previous one wrote (keys, the previous layer).
    auto cmdBarrier = [&] {
      cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                       VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT |
                           VK_ACCESS_2_TRANSFER_WRITE_BIT,
                       VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                       VK_ACCESS_2_SHADER_STORAGE_READ_BIT | VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT |
                           VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT);
    };
    uint32_t pointGroups = uint32_t(std::clamp<uint64_t>((points.size() + 255) / 256, 1, kMaxGroups));
    uint32_t texelGroups = uint32_t(std::clamp<uint64_t>((layerTexels + 255) / 256, 1, kMaxGroups));
    for (uint32_t layer = 0; layer < config.layers; ++layer) {
      // Splat: every texel starts empty (all ones: farther than any disc); one thread per (point, view).
      uint32_t slot = timer.cmdBegin(cmd, "splat");
      if (layer) cmdBarrier(); // the previous layer's resolve read the keys
      vkCmdFillBuffer(cmd, keys.handle(), 0, VK_WHOLE_SIZE, ~0u);
      cmdBarrier();
      push.previousLayer = layer ? out.positions.address() + (layer - 1) * layerTexels * 16 : 0;
      push.positions = out.positions.address() + layer * layerTexels * 16;
      push.normals = normals.address() + layer * layerTexels * 8;
      push.colors = colors.address() + layer * layerTexels * 4;
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, splat);
      vkCmdPushConstants(cmd, layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
      vkCmdDispatch(cmd, pointGroups, config.views, 1); // views <= 65535, checked above
      timer.cmdEnd(cmd, slot);
      // Resolve: each texel's winning disc into this layer's positions / normals / colours.
      cmdBarrier();
      slot = timer.cmdBegin(cmd, "resolve");
      vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, resolve);
      vkCmdPushConstants(cmd, layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
      vkCmdDispatch(cmd, texelGroups, 1, 1);
      timer.cmdEnd(cmd, slot);
    }
    // Copy: the three targets to the host (the positions stay on the GPU for the sampler too).
    cmdBarrier();
    uint32_t slot = timer.cmdBegin(cmd, "copy");
    const Buffer* sources[3] = {&out.positions, &normals, &colors};
    for (int i = 0; i < 3; ++i) {
      VkBufferCopy whole{0, 0, texelCount * bytesPerTexel[i]};
      vkCmdCopyBuffer(cmd, sources[i]->handle(), readback[i].handle(), 1, &whole);
    }
    cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_PIPELINE_STAGE_2_HOST_BIT,
                     VK_ACCESS_2_HOST_READ_BIT);
    timer.cmdEnd(cmd, slot);
  });
  // One time per stage, summed over layers.
  for (const PassTime& pass : timer.read()) {
    auto same =
        std::find_if(out.times.begin(), out.times.end(), [&](const PassTime& p) { return p.name == pass.name; });
    if (same == out.times.end())
      out.times.push_back(pass);
    else
      same->milliseconds += pass.milliseconds;
  }

  const float* pos4 = reinterpret_cast<const float*>(readback[0].mapped());
  detail::compactTexels(t, pos4, reinterpret_cast<const uint16_t*>(readback[1].mapped()),
                        reinterpret_cast<const uint32_t*>(readback[2].mapped()), texelCount);
  detail::computeAreas(t, out.views, pos4);
  if (t.size() == 0) return makeError(source, "no disc covered a texel (resolution too low for the cloud?)");
  return out;
}

} // namespace mirage::surfels
