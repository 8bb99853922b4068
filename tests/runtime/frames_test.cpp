// runtime::Scene frames in flight (docs/runtime.md "Frames in flight"): three frames recorded into
// slots 0..2 before any wait, the eye changing PVS cell between them (the replaced cluster PVS must
// outlive the frames reading it, with no device wait), give the images and counters of three
// sequential render() calls.
#include <cstring>

#include <glm/gtc/packing.hpp>
#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/gpu/commands.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "mirage/runtime/scene.h"
#include "mirage/visibility/pvs_storage.h"
#include "mirage/visibility/ray_backend.h"
#include "test_support.h"

using namespace mirage;
using mirage::test::GpuTest;
namespace fs = std::filesystem;

namespace {

constexpr uint32_t kWidth = 64, kHeight = 48;

class RuntimeFrames : public GpuTest {};

} // namespace

TEST_F(RuntimeFrames, ThreeRecordedFramesMatchSequentialRenders) {
  static_assert(render::kMaxFramesInFlight == 3);
  // A city whose PVS has two cells: cell 0 sees everything, cell 1 only the first instance.
  mirage::Scene city = io::generateScene("city", 1, 1).value();
  fs::path dir = test::tempDir("runtime_frames");
  fs::path mrg = dir / "city.mrg", pvsPath = dir / "pvs.mrg";
  ASSERT_TRUE(lod::saveLodAsset(mrg.string(), lod::bakeLodAsset(city, {}).value()).ok());
  render::Camera base = render::autoCamera(city.worldBounds(), float(kWidth) / float(kHeight));
  glm::vec3 step = glm::normalize(glm::cross(base.target - base.eye, glm::vec3(0, 1, 0))) * 2.0f;
  vis::PvsData pvs;
  pvs.sceneTriangles = city.instancedTriangleCount();
  pvs.cells.resize(2);
  pvs.cells[0].position = base.eye;
  pvs.cells[1].position = base.eye + step;
  std::vector<uint64_t> offsets = vis::triangleOffsets(city);
  pvs.triangles.resize(2);
  for (uint32_t t = 0; t < pvs.sceneTriangles; ++t) pvs.triangles[0].push_back(t);
  for (uint64_t t = offsets[0]; t < offsets[1]; ++t) pvs.triangles[1].push_back(uint32_t(t));
  ASSERT_TRUE(vis::savePvs(pvsPath.string(), pvs, "gen:city:1").ok());

  const runtime::SceneOptions options{.input = mrg.string(), .pvs = pvsPath.string()};
  auto sequential = runtime::Scene::open(test::gpuContext(), options);
  auto inFlight = runtime::Scene::open(test::gpuContext(), options);
  ASSERT_TRUE(sequential.ok() && inFlight.ok());
  ASSERT_TRUE((*inFlight)->canRecord());
  std::vector<runtime::View> views(render::kMaxFramesInFlight);
  const int cells[] = {0, 1, 0}; // a cell change while the frames before it are in flight
  for (uint32_t i = 0; i < views.size(); ++i) {
    views[i].width = kWidth;
    views[i].height = kHeight;
    views[i].camera = base;
    views[i].camera.eye = pvs.cells[size_t(cells[i])].position + glm::vec3(0.0f, 0.1f * float(i), 0.0f);
    views[i].camera.target = base.target + (views[i].camera.eye - base.eye);
    views[i].readLinear = true;
  }
  std::vector<runtime::Frame> expected;
  for (const runtime::View& v : views) {
    auto f = (*sequential)->render(v);
    ASSERT_TRUE(f.ok()) << f.error().message;
    expected.push_back(std::move(*f));
  }
  EXPECT_NE(expected[0].trianglesDrawn, expected[1].trianglesDrawn); // the slots can be told apart

  gpu::Context& ctx = test::gpuContext();
  VkDevice device = ctx.device();
  VkCommandPoolCreateInfo pi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pi.queueFamilyIndex = ctx.queueFamily();
  VkCommandPool pool = VK_NULL_HANDLE;
  ASSERT_EQ(vkCreateCommandPool(device, &pi, nullptr, &pool), VK_SUCCESS);
  VkCommandBuffer cmds[render::kMaxFramesInFlight];
  VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ai.commandPool = pool;
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = render::kMaxFramesInFlight;
  ASSERT_EQ(vkAllocateCommandBuffers(device, &ai, cmds), VK_SUCCESS);
  VkFence fences[render::kMaxFramesInFlight];
  std::vector<gpu::Buffer> pixels;
  for (uint32_t i = 0; i < render::kMaxFramesInFlight; ++i) {
    VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    ASSERT_EQ(vkCreateFence(device, &fi, nullptr, &fences[i]), VK_SUCCESS);
    pixels.push_back(gpu::createBuffer(ctx, uint64_t(kWidth) * kHeight * 8, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                       gpu::MemoryUsage::Readback, "frame pixels"));
  }
  for (uint32_t i = 0; i < render::kMaxFramesInFlight; ++i) {
    VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    ASSERT_EQ(vkBeginCommandBuffer(cmds[i], &bi), VK_SUCCESS);
    Status recorded = (*inFlight)->record(cmds[i], views[i], i);
    ASSERT_TRUE(recorded.ok()) << recorded.error().message;
    const gpu::Image* color = (*inFlight)->colorTarget();
    ASSERT_NE(color, nullptr);
    ASSERT_EQ(color->format(), VK_FORMAT_R16G16B16A16_SFLOAT);
    gpu::cmdImageBarrier(cmds[i],
                         {color->handle(), VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                          VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_GENERAL,
                          VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL});
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {kWidth, kHeight, 1};
    vkCmdCopyImageToBuffer(cmds[i], color->handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, pixels[i].handle(), 1,
                           &region);
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
  ASSERT_EQ(vkWaitForFences(device, render::kMaxFramesInFlight, fences, VK_TRUE, UINT64_MAX), VK_SUCCESS);

  for (uint32_t i = 0; i < render::kMaxFramesInFlight; ++i) {
    SCOPED_TRACE(i);
    auto out = (*inFlight)->collect(i);
    ASSERT_TRUE(out.ok()) << out.error().message;
    EXPECT_TRUE(out->srgb.pixels.empty()); // no readback on this path
    EXPECT_EQ(out->pvsCell, expected[i].pvsCell);
    EXPECT_EQ(out->pvsCell, cells[i]);
    EXPECT_EQ(out->trianglesDrawn, expected[i].trianglesDrawn);
    EXPECT_EQ(out->clustersDrawn, expected[i].clustersDrawn);
    ASSERT_TRUE(out->cluster && expected[i].cluster);
    EXPECT_EQ(out->cluster->instancesPvsCulled, expected[i].cluster->instancesPvsCulled);
    EXPECT_EQ(out->cluster->clustersSelected, expected[i].cluster->clustersSelected);
    EXPECT_FALSE(out->passTimes.empty());
    std::vector<uint16_t> half(size_t(kWidth) * kHeight * 4);
    std::memcpy(half.data(), pixels[i].mapped(), half.size() * 2);
    ASSERT_EQ(expected[i].linear.pixels.size(), half.size());
    size_t differing = 0;
    for (size_t k = 0; k < half.size(); ++k) differing += glm::unpackHalf1x16(half[k]) != expected[i].linear.pixels[k];
    EXPECT_EQ(differing, 0u) << "of " << half.size() << " channel values";
    EXPECT_FALSE((*inFlight)->collect(i).ok()); // a slot is collected once
  }
  for (VkFence f : fences) vkDestroyFence(device, f, nullptr);
  vkDestroyCommandPool(device, pool, nullptr);
}

TEST_F(RuntimeFrames, ScenesWithoutARecordPathSaySo) {
  auto forward = runtime::Scene::open(test::gpuContext(), {.input = "gen:blob:1"});
  ASSERT_TRUE(forward.ok()) << forward.error().message;
  EXPECT_FALSE((*forward)->canRecord());
  EXPECT_EQ((*forward)->colorTarget(), nullptr);
  runtime::View v;
  auto st = (*forward)->record(VK_NULL_HANDLE, v, 0);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.error().message.find("render()"), std::string::npos) << st.error().message;
}
