// Cluster renderer frames in flight (record / collect): frames recorded into every slot and
// submitted before any wait, as a viewer does, give exactly the images and stats of sequential
// render() calls. Validation (with synchronization validation) must stay silent.
#include <gtest/gtest.h>

#include <glm/gtc/packing.hpp>

#include <cstring>
#include <vector>

#include "gpu_test.h"
#include "mirage/gpu/commands.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/render/cluster_renderer.h"

using namespace mirage;
using namespace mirage::render;

namespace {

constexpr uint32_t kSize = 96;

const lod::LodAsset& blobAsset() {
  static lod::LodAsset asset = [] {
    io::BlobOptions o;
    o.subdivisions = 4;
    auto baked = lod::bakeLodAsset(io::generateBlob(o), lod::BuildConfig{});
    if (!baked) std::abort();
    return std::move(*baked);
  }();
  return asset;
}

// Three different frames: camera, LOD threshold and selection mode (the hierarchical ones read
// their traversal counters back too), so a slot mixing up another's data shows.
std::vector<ClusterRenderSettings> threeFrames(const Bounds& bounds) {
  std::vector<ClusterRenderSettings> frames;
  Camera far = autoCamera(bounds, 1.0f);
  Camera close = far;
  close.eye = glm::mix(far.target, far.eye, 0.5f);
  Camera side = far;
  side.eye = glm::vec3(-far.eye.z, far.eye.y, far.eye.x);
  const Camera cams[3] = {far, close, side};
  const float taus[3] = {1.0f, 4.0f, 0.5f};
  const SelectionMode modes[3] = {SelectionMode::Flat, SelectionMode::Hierarchy, SelectionMode::Dag};
  for (int i = 0; i < 3; ++i) {
    ClusterRenderSettings s;
    s.base.width = s.base.height = kSize;
    s.base.camera = cams[i];
    s.base.background = {0, 0, 0, 1};
    s.base.readLinear = true;
    s.tauPixels = taus[i];
    s.selection = modes[i];
    frames.push_back(s);
  }
  return frames;
}

void expectSameStats(const ClusterStats& a, const ClusterStats& b) {
  EXPECT_EQ(a.instancesVisible, b.instancesVisible);
  EXPECT_EQ(a.clustersTested, b.clustersTested);
  EXPECT_EQ(a.nodesTested, b.nodesTested);
  EXPECT_EQ(a.selectionPasses, b.selectionPasses);
  EXPECT_EQ(a.clustersSelected, b.clustersSelected);
  EXPECT_EQ(a.clustersFrustumCulled, b.clustersFrustumCulled);
  EXPECT_EQ(a.clustersBackfaceCulled, b.clustersBackfaceCulled);
  EXPECT_EQ(a.clustersDrawn, b.clustersDrawn);
  EXPECT_EQ(a.clustersHardware, b.clustersHardware);
  EXPECT_EQ(a.trianglesRasterized, b.trianglesRasterized);
  EXPECT_EQ(a.selection, b.selection);
  EXPECT_EQ(a.raster, b.raster);
}

} // namespace

class ClusterFrames : public test::GpuTest {};

TEST_F(ClusterFrames, ThreeFramesInFlightMatchSequentialRenders) {
  static_assert(kMaxFramesInFlight == 3);
  gpu::Context& ctx = context();
  auto sequential = ClusterRenderer::create(ctx, blobAsset());
  auto inFlight = ClusterRenderer::create(ctx, blobAsset());
  ASSERT_TRUE(sequential.ok() && inFlight.ok());
  std::vector<ClusterRenderSettings> frames = threeFrames((*sequential)->worldBounds());
  std::vector<ClusterRenderOutput> expected;
  for (const ClusterRenderSettings& s : frames) {
    auto out = (*sequential)->render(s);
    ASSERT_TRUE(out.ok()) << out.error().message;
    expected.push_back(std::move(*out));
  }
  // The stats differ between the frames, or the test could not tell the slots apart.
  EXPECT_NE(expected[0].stats.trianglesRasterized, expected[1].stats.trianglesRasterized);

  // A viewer's loop without waits: each frame's command buffer records the frame and copies the
  // colour target out (as a swapchain blit would), then is submitted with its own fence.
  VkDevice device = ctx.device();
  VkCommandPoolCreateInfo pi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pi.queueFamilyIndex = ctx.queueFamily();
  VkCommandPool pool = VK_NULL_HANDLE;
  ASSERT_EQ(vkCreateCommandPool(device, &pi, nullptr, &pool), VK_SUCCESS);
  VkCommandBuffer cmds[kMaxFramesInFlight];
  VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ai.commandPool = pool;
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = kMaxFramesInFlight;
  ASSERT_EQ(vkAllocateCommandBuffers(device, &ai, cmds), VK_SUCCESS);
  VkFence fences[kMaxFramesInFlight];
  std::vector<gpu::Buffer> pixels;
  for (uint32_t i = 0; i < kMaxFramesInFlight; ++i) {
    VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    ASSERT_EQ(vkCreateFence(device, &fi, nullptr, &fences[i]), VK_SUCCESS);
    pixels.push_back(gpu::createBuffer(ctx, uint64_t(kSize) * kSize * 8, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                       gpu::MemoryUsage::Readback, "frame pixels"));
  }
  for (uint32_t i = 0; i < kMaxFramesInFlight; ++i) {
    VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    ASSERT_EQ(vkBeginCommandBuffer(cmds[i], &bi), VK_SUCCESS);
    Status recorded = (*inFlight)->record(cmds[i], frames[i], i);
    ASSERT_TRUE(recorded.ok()) << recorded.error().message;
    gpu::cmdImageBarrier(cmds[i], {(*inFlight)->colorTarget().handle(), VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                                   VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                                   VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_GENERAL,
                                   VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL});
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {kSize, kSize, 1};
    vkCmdCopyImageToBuffer(cmds[i], (*inFlight)->colorTarget().handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                           pixels[i].handle(), 1, &region);
    gpu::cmdMemoryBarrier(cmds[i], VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                          VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
    ASSERT_EQ(vkEndCommandBuffer(cmds[i]), VK_SUCCESS);
    VkCommandBufferSubmitInfo cbi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO};
    cbi.commandBuffer = cmds[i];
    VkSubmitInfo2 si{VK_STRUCTURE_TYPE_SUBMIT_INFO_2};
    si.commandBufferInfoCount = 1;
    si.pCommandBufferInfos = &cbi;
    ASSERT_EQ(vkQueueSubmit2(ctx.queue(), 1, &si, fences[i]), VK_SUCCESS);
  }
  ASSERT_EQ(vkWaitForFences(device, kMaxFramesInFlight, fences, VK_TRUE, UINT64_MAX), VK_SUCCESS);

  for (uint32_t i = 0; i < kMaxFramesInFlight; ++i) {
    SCOPED_TRACE(i);
    auto out = (*inFlight)->collect(i);
    ASSERT_TRUE(out.ok()) << out.error().message;
    expectSameStats(out->stats, expected[i].stats);
    EXPECT_FALSE(out->image.stats.passTimes.empty());
    std::vector<uint16_t> half(size_t(kSize) * kSize * 4);
    std::memcpy(half.data(), pixels[i].mapped(), half.size() * 2);
    size_t differing = 0;
    for (size_t k = 0; k < half.size(); ++k)
      differing += glm::unpackHalf1x16(half[k]) != expected[i].image.linear.pixels[k];
    EXPECT_EQ(differing, 0u) << "of " << half.size() << " channel values";
    // A slot is collected once.
    EXPECT_FALSE((*inFlight)->collect(i).ok());
  }
  EXPECT_FALSE((*inFlight)->record(cmds[0], frames[0], kMaxFramesInFlight).ok()); // no fourth slot (nothing recorded)
  for (VkFence f : fences) vkDestroyFence(device, f, nullptr);
  vkDestroyCommandPool(device, pool, nullptr);
}
