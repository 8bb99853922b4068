// The viewer's GPU present path (present.h): a scene frame recorded into a command buffer and
// encoded from the scene's colour target (RGBA16F, linear) into a BGRA8 UNORM "swapchain" image
// shows the same sRGB bytes as the readback path (Scene::render), with no window needed: the
// swapchain image is an ordinary image of the swapchain's format. The part of the image beyond
// the frame is cleared.
#include <cstdlib>
#include <cstring>

#include <gtest/gtest.h>

#include "gpu_test.h"
#include "mirage/gpu/commands.h"
#include "mirage/io/generate.h"
#include "mirage/lod/lod_asset.h"
#include "present.h"
#include "scene_view.h"
#include "test_support.h"

using namespace mirage;

class ViewerPresent : public test::GpuTest {};

TEST_F(ViewerPresent, BlitOfTheColourTargetEqualsTheReadbackImage) {
  constexpr uint32_t kWidth = 64, kHeight = 48, kMargin = 8; // the "swapchain" is larger by kMargin
  gpu::Context& ctx = test::gpuContext();
  std::filesystem::path mrg = test::tempDir("viewer_present") / "blob.mrg";
  mirage::Scene blob = io::generateScene("blob", 1, 3).value();
  ASSERT_TRUE(lod::saveLodAsset(mrg.string(), lod::bakeLodAsset(blob, {}).value()).ok());
  auto scene = viewer::SceneView::open(ctx, {.path = mrg.string()});
  ASSERT_TRUE(scene.ok()) << scene.error().message;
  viewer::View view;
  view.width = kWidth;
  view.height = kHeight;
  view.camera = render::autoCamera((*scene)->bounds(), float(kWidth) / float(kHeight));

  viewer::TargetBlit blit = viewer::createTargetBlit(ctx, VK_FORMAT_B8G8R8A8_UNORM);
  ASSERT_EQ(blit.format, VK_FORMAT_B8G8R8A8_UNORM);
  const uint32_t sw = kWidth + kMargin, sh = kHeight + kMargin;
  gpu::Image swap = gpu::createImage2D(ctx, sw, sh, VK_FORMAT_B8G8R8A8_UNORM,
                                       VK_IMAGE_USAGE_TRANSFER_DST_BIT | VK_IMAGE_USAGE_TRANSFER_SRC_BIT |
                                           VK_IMAGE_USAGE_COLOR_ATTACHMENT_BIT,
                                       "fake swapchain image");
  gpu::Buffer pixels = gpu::createBuffer(ctx, uint64_t(sw) * sh * 4, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                         gpu::MemoryUsage::Readback, "presented pixels");
  Status recorded = Ok{};
  ctx.submitAndWait([&](VkCommandBuffer cmd) {
    gpu::Swapchain::Frame frame;
    frame.cmd = cmd;
    frame.image = swap.handle();
    frame.view = swap.view();
    frame.extent = {sw, sh};
    recorded = (*scene)->record(cmd, view, frame.slot);
    if (!recorded) return;
    viewer::cmdBlitTargetToSwapchain(ctx, blit, frame, *(*scene)->colorTarget());
    gpu::cmdImageBarrier(cmd, {.image = swap.handle(),
                               .srcStage = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                               .srcAccess = VK_ACCESS_2_MEMORY_WRITE_BIT,
                               .dstStage = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                               .dstAccess = VK_ACCESS_2_TRANSFER_READ_BIT,
                               .oldLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                               .newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL});
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {sw, sh, 1};
    vkCmdCopyImageToBuffer(cmd, swap.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, pixels.handle(), 1, &region);
    gpu::cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                          VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
  });
  ASSERT_TRUE(recorded.ok()) << recorded.error().message;
  auto stats = (*scene)->collect(0);
  ASSERT_TRUE(stats.ok()) << stats.error().message;
  auto expected = (*scene)->render(view);
  ASSERT_TRUE(expected.ok()) << expected.error().message;
  EXPECT_EQ(stats->triangles, expected->stats.triangles);

  const uint8_t* bgra = pixels.mapped();
  const ImageRGBA8& rgba = expected->srgb;
  ASSERT_EQ(rgba.width, kWidth);
  int worst = 0;
  size_t margin = 0;
  for (uint32_t y = 0; y < sh; ++y)
    for (uint32_t x = 0; x < sw; ++x) {
      const uint8_t* p = bgra + (size_t(y) * sw + x) * 4;
      if (x >= kWidth || y >= kHeight) {
        margin += p[0] != 0 || p[1] != 0 || p[2] != 0;
        continue;
      }
      const uint8_t* q = &rgba.pixels[(size_t(y) * kWidth + x) * 4];
      worst = std::max(
          {worst, std::abs(int(p[2]) - int(q[0])), std::abs(int(p[1]) - int(q[1])), std::abs(int(p[0]) - int(q[2]))});
    }
  // The shader encodes as the CPU does (linearToSrgb8); float pow may still differ by a level.
  EXPECT_LE(worst, 1);
  EXPECT_EQ(margin, 0u) << "pixels beyond the frame not cleared";
}
