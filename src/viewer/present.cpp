#include "present.h"

#include <algorithm>
#include <cstring>

#include "mirage/gpu/commands.h"

namespace mirage::viewer {

void cmdCopyFrameToSwapchain(gpu::Context& context, PresentStaging& staging, const gpu::Swapchain::Frame& frame,
                             VkFormat format, const ImageRGBA8& image) {
  VkCommandBuffer cmd = frame.cmd;
  uint32_t w = std::min(image.width, frame.extent.width), h = std::min(image.height, frame.extent.height);
  size_t bytes = size_t(image.width) * image.height * 4;
  if (staging.buffers.size() <= frame.slot) staging.buffers.resize(frame.slot + 1);
  gpu::Buffer& buffer = staging.buffers[frame.slot];
  if (bytes && (!buffer || buffer.size() < bytes))
    buffer = gpu::createBuffer(context, bytes, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, gpu::MemoryUsage::Upload,
                               "present staging");
  if (bytes) {
    if (format == VK_FORMAT_B8G8R8A8_UNORM || format == VK_FORMAT_B8G8R8A8_SRGB) {
      const uint8_t* src = image.pixels.data();
      uint8_t* dst = buffer.mapped();
      for (size_t i = 0; i < bytes; i += 4) {
        dst[i] = src[i + 2];
        dst[i + 1] = src[i + 1];
        dst[i + 2] = src[i];
        dst[i + 3] = src[i + 3];
      }
    } else {
      std::memcpy(buffer.mapped(), image.pixels.data(), bytes);
    }
  }

  gpu::cmdImageBarrier(cmd, {.image = frame.image,
                             .srcStage = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, // the acquire semaphore's wait stage
                             .dstStage = VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                             .dstAccess = VK_ACCESS_2_TRANSFER_WRITE_BIT,
                             .oldLayout = VK_IMAGE_LAYOUT_UNDEFINED,
                             .newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL});
  if (w < frame.extent.width || h < frame.extent.height) {
    VkClearColorValue black{};
    VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdClearColorImage(cmd, frame.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &black, 1, &range);
    gpu::cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                          VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT);
  }
  if (w && h) {
    VkBufferImageCopy region{};
    region.bufferRowLength = image.width;
    region.bufferImageHeight = image.height;
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {w, h, 1};
    vkCmdCopyBufferToImage(cmd, buffer.handle(), frame.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
  }
  gpu::cmdImageBarrier(cmd,
                       {.image = frame.image,
                        .srcStage = VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                        .srcAccess = VK_ACCESS_2_TRANSFER_WRITE_BIT,
                        .dstStage = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                        .dstAccess = VK_ACCESS_2_COLOR_ATTACHMENT_READ_BIT | VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                        .oldLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
                        .newLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL});
}

void cmdTransitionForPresent(VkCommandBuffer cmd, VkImage image) {
  gpu::cmdImageBarrier(cmd, {.image = image,
                             .srcStage = VK_PIPELINE_STAGE_2_COLOR_ATTACHMENT_OUTPUT_BIT,
                             .srcAccess = VK_ACCESS_2_COLOR_ATTACHMENT_WRITE_BIT,
                             .dstStage = VK_PIPELINE_STAGE_2_NONE,
                             .oldLayout = VK_IMAGE_LAYOUT_COLOR_ATTACHMENT_OPTIMAL,
                             .newLayout = VK_IMAGE_LAYOUT_PRESENT_SRC_KHR});
}

} // namespace mirage::viewer
