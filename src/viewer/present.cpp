#include "present.h"

#include <algorithm>
#include <cstring>

#include "mirage/gpu/commands.h"
#include "mirage/gpu/pipeline.h"

namespace mirage::viewer {

namespace {

// Copies w x h packed RGBA8 pixels (rows of `rowLength` pixels) from `buffer` into the swapchain
// image (in TRANSFER_DST_OPTIMAL, earlier writes to both made available), then hands the image to
// the overlay's colour attachment.
void cmdCopyPackedToSwapchain(VkCommandBuffer cmd, VkBuffer buffer, uint32_t rowLength, uint32_t rows,
                              const gpu::Swapchain::Frame& frame, uint32_t w, uint32_t h) {
  if (w && h) {
    VkBufferImageCopy region{};
    region.bufferRowLength = rowLength;
    region.bufferImageHeight = rows;
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {w, h, 1};
    vkCmdCopyBufferToImage(cmd, buffer, frame.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
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

} // namespace

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
  cmdCopyPackedToSwapchain(cmd, buffer.handle(), image.width, image.height, frame, w, h);
}

namespace {

struct SrgbPush { // present_srgb.comp
  VkDeviceAddress src = 0, dst = 0;
  uint32_t pixels = 0, bgra = 0;
};

} // namespace

TargetBlit createTargetBlit(gpu::Context& context, VkFormat format) {
  TargetBlit blit;
  if (format != VK_FORMAT_B8G8R8A8_UNORM && format != VK_FORMAT_R8G8B8A8_UNORM) return blit;
  blit.layout = gpu::createPipelineLayout(context, {}, sizeof(SrgbPush), VK_SHADER_STAGE_COMPUTE_BIT);
  blit.pipeline = gpu::createComputePipeline(context, "present_srgb.comp", blit.layout);
  blit.format = format;
  return blit;
}

void slotCompleted(TargetBlit& blit, uint32_t slot) {
  blit.retired.completed(slot);
  blit.inFlight &= ~(1u << slot);
}

void cmdBlitTargetToSwapchain(gpu::Context& context, TargetBlit& blit, const gpu::Swapchain::Frame& frame,
                              const gpu::Image& target) {
  VkCommandBuffer cmd = frame.cmd;
  VkExtent3D size = target.extent();
  uint32_t pixels = size.width * size.height;
  if (!blit.half || blit.half.size() < uint64_t(pixels) * 8) {
    blit.retired.retire(std::move(blit.half), blit.inFlight); // earlier frames may still use them
    blit.retired.retire(std::move(blit.packed), blit.inFlight);
    blit.half = gpu::createBuffer(context, uint64_t(pixels) * 8, VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                                  gpu::MemoryUsage::GpuOnly, "present half");
    blit.packed = gpu::createBuffer(context, uint64_t(pixels) * 4, VK_BUFFER_USAGE_TRANSFER_SRC_BIT,
                                    gpu::MemoryUsage::GpuOnly, "present srgb");
  }
  blit.inFlight |= 1u << frame.slot;
  uint32_t w = std::min(size.width, frame.extent.width), h = std::min(size.height, frame.extent.height);

  // The target was last written by the frame's compute shaders; the buffers were last used by an
  // earlier frame (queue order: the all-commands barrier below covers it); the swapchain image
  // waits for the acquire semaphore (all commands).
  gpu::cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT,
                        VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
                        VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT);
  const gpu::ImageBarrier before[] = {
      {.image = target.handle(),
       .srcStage = VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
       .srcAccess = VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
       .dstStage = VK_PIPELINE_STAGE_2_COPY_BIT,
       .dstAccess = VK_ACCESS_2_TRANSFER_READ_BIT,
       .oldLayout = VK_IMAGE_LAYOUT_GENERAL,
       .newLayout = VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL},
      {.image = frame.image,
       .srcStage = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT,
       .dstStage = VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
       .dstAccess = VK_ACCESS_2_TRANSFER_WRITE_BIT,
       .oldLayout = VK_IMAGE_LAYOUT_UNDEFINED,
       .newLayout = VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL},
  };
  gpu::cmdImageBarriers(cmd, before);
  VkBufferImageCopy whole{};
  whole.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
  whole.imageExtent = {size.width, size.height, 1};
  vkCmdCopyImageToBuffer(cmd, target.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, blit.half.handle(), 1, &whole);
  gpu::cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                        VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_READ_BIT);
  SrgbPush push{blit.half.address(), blit.packed.address(), pixels, blit.format == VK_FORMAT_B8G8R8A8_UNORM ? 1u : 0u};
  vkCmdBindPipeline(cmd, VK_PIPELINE_BIND_POINT_COMPUTE, blit.pipeline);
  vkCmdPushConstants(cmd, blit.layout, VK_SHADER_STAGE_COMPUTE_BIT, 0, sizeof(push), &push);
  gpu::DispatchRows rows = gpu::dispatchRows((pixels + 255) / 256);
  vkCmdDispatch(cmd, rows.x, rows.y, 1);
  if (w < frame.extent.width || h < frame.extent.height) {
    VkClearColorValue black{};
    VkImageSubresourceRange range{VK_IMAGE_ASPECT_COLOR_BIT, 0, 1, 0, 1};
    vkCmdClearColorImage(cmd, frame.image, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, &black, 1, &range);
  }
  // The packed pixels (and the clear) before the copy into the swapchain image.
  gpu::cmdMemoryBarrier(cmd, VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT | VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT,
                        VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT,
                        VK_PIPELINE_STAGE_2_COPY_BIT, VK_ACCESS_2_TRANSFER_READ_BIT | VK_ACCESS_2_TRANSFER_WRITE_BIT);
  cmdCopyPackedToSwapchain(cmd, blit.packed.handle(), size.width, size.height, frame, w, h);
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
