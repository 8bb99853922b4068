// The swapchain on a real window: presents, follows a resize, switches present modes, with the
// validation layers silent. Needs an X server: tests/cli/view.sh runs it under Xvfb; without a
// display it skips.
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <gtest/gtest.h>

#include "mirage/gpu/commands.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/swapchain.h"
#include "window.h"

using namespace mirage;

namespace {

// Clears `frames` swapchain images and presents them; returns how many were presented.
int presentFrames(gpu::Swapchain& swapchain, viewer::Window& window, int frames) {
  int presented = 0;
  for (int i = 0; i < frames; ++i) {
    window.poll();
    auto f = swapchain.beginFrame(window.framebufferSize());
    if (!f) continue;
    gpu::cmdImageBarrier(f->cmd, {.image = f->image,
                                  .srcStage = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
                                  .dstStage = VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                                  .dstAccess = VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                  .oldLayout = VK_IMAGE_LAYOUT_UNDEFINED,
                                  .newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL});
    VkClearColorValue colour{{0.2f, 0.4f, float(i % 2), 1.0f}};
    VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdClearColorImage(f->cmd, f->image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &colour, 1, &range);
    gpu::cmdImageBarrier(f->cmd, {.image = f->image,
                                  .srcStage = VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                                  .srcAccess = VK_ACCESS_2_TRANSFER_WRITE_BIT,
                                  .dstStage = VK_PIPELINE_STAGE_2_NONE,
                                  .oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                                  .newLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR});
    swapchain.endFrame(*f);
    ++presented;
  }
  return presented;
}

} // namespace

TEST(SwapchainWindow, PresentsFollowsResizeAndSwitchesPresentModes) {
  auto system = viewer::WindowSystem::start();
  if (!system) GTEST_SKIP() << "no X server: " << system.error().message;
  gpu::ContextOptions co;
  co.validation = true;
  co.instanceExtensions = (*system)->instanceExtensions();
  co.swapchain = true;
  auto ctx = gpu::Context::create(co);
  ASSERT_TRUE(ctx) << ctx.error().message;
  {
    auto window = viewer::Window::create(160, 120, "swapchain test");
    ASSERT_TRUE(window) << window.error().message;
    auto surface = (*window)->createSurface((*ctx)->instance());
    ASSERT_TRUE(surface) << surface.error().message;
    auto swapchain = gpu::Swapchain::create(**ctx, *surface, (*window)->framebufferSize(), {});
    ASSERT_TRUE(swapchain) << swapchain.error().message;
    gpu::Swapchain& sc = **swapchain;
    EXPECT_EQ(sc.framesInFlight(), 2u);
    EXPECT_EQ(presentFrames(sc, **window, 4), 4);
    EXPECT_EQ(sc.extent().width, 160u);
    EXPECT_EQ(sc.extent().height, 120u);
    EXPECT_EQ(sc.presentMode(), VK_PRESENT_MODE_FIFO_KHR);

    glfwSetWindowSize((*window)->handle(), 200, 100);
    for (int i = 0; i < 50 && (*window)->framebufferSize().width != 200; ++i) (*window)->waitEvents();
    EXPECT_GE(presentFrames(sc, **window, 4), 3); // one may be lost to the out-of-date swapchain
    EXPECT_EQ(sc.extent().width, 200u);
    EXPECT_EQ(sc.extent().height, 100u);

    for (gpu::PresentMode mode : {gpu::PresentMode::Immediate, gpu::PresentMode::Mailbox, gpu::PresentMode::Fifo}) {
      sc.setPresentMode(mode);
      EXPECT_GE(presentFrames(sc, **window, 3), 2) << gpu::toString(mode);
      EXPECT_EQ(sc.requestedPresentMode(), mode);
    }
  }
  EXPECT_EQ((*ctx)->validationIssues(), 0u);
}
