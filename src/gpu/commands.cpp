#include "mirage/gpu/commands.h"

#include <algorithm>
#include <bit>
#include <cstring>

#include "mirage/gpu/context.h"

namespace mirage::gpu {

void cmdImageBarriers(VkCommandBuffer cmd, std::span<const ImageBarrier> barriers) {
  std::vector<VkImageMemoryBarrier2> list;
  list.reserve(barriers.size());
  for (const ImageBarrier& b : barriers) {
    VkImageMemoryBarrier2 ib{VK_STRUCTURE_TYPE_IMAGE_MEMORY_BARRIER_2};
    ib.srcStageMask = b.srcStage;
    ib.srcAccessMask = b.srcAccess;
    ib.dstStageMask = b.dstStage;
    ib.dstAccessMask = b.dstAccess;
    ib.oldLayout = b.oldLayout;
    ib.newLayout = b.newLayout;
    ib.srcQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    ib.dstQueueFamilyIndex = VK_QUEUE_FAMILY_IGNORED;
    ib.image = b.image;
    ib.subresourceRange = {b.aspect, b.baseMip, b.mipLevels, 0, b.layers};
    list.push_back(ib);
  }
  VkDependencyInfo di{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  di.imageMemoryBarrierCount = uint32_t(list.size());
  di.pImageMemoryBarriers = list.data();
  vkCmdPipelineBarrier2(cmd, &di);
}

void cmdSetFullViewport(VkCommandBuffer cmd, uint32_t width, uint32_t height) {
  VkViewport vp{0.0f, 0.0f, float(width), float(height), 0.0f, 1.0f};
  VkRect2D scissor{{0, 0}, {width, height}};
  vkCmdSetViewport(cmd, 0, 1, &vp);
  vkCmdSetScissor(cmd, 0, 1, &scissor);
}

void cmdMemoryBarrier(VkCommandBuffer cmd, VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                      VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess) {
  VkMemoryBarrier2 mb{VK_STRUCTURE_TYPE_MEMORY_BARRIER_2};
  mb.srcStageMask = srcStage;
  mb.srcAccessMask = srcAccess;
  mb.dstStageMask = dstStage;
  mb.dstAccessMask = dstAccess;
  VkDependencyInfo di{VK_STRUCTURE_TYPE_DEPENDENCY_INFO};
  di.memoryBarrierCount = 1;
  di.pMemoryBarriers = &mb;
  vkCmdPipelineBarrier2(cmd, &di);
}

uint32_t mipLevelCount(uint32_t width, uint32_t height) {
  return uint32_t(std::bit_width(std::max(1u, std::max(width, height))));
}

void uploadBuffer(Context& context, const Buffer& dst, const void* data, size_t size, size_t dstOffset) {
  // Chunked so a huge mesh never needs a staging buffer as large as itself.
  constexpr size_t kChunk = 64ull << 20;
  Buffer staging =
      createBuffer(context, std::min(size, kChunk), VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUsage::Upload, "staging");
  for (size_t done = 0; done < size; done += kChunk) {
    size_t n = std::min(kChunk, size - done);
    std::memcpy(staging.mapped(), static_cast<const uint8_t*>(data) + done, n);
    // barriers: the one-shot submit waits for completion, so staging reuse is safe.
    context.submitAndWait([&](VkCommandBuffer cmd) {
      VkBufferCopy region{0, dstOffset + done, n};
      vkCmdCopyBuffer(cmd, staging.handle(), dst.handle(), 1, &region);
    });
  }
}

std::vector<uint8_t> readbackBuffer(Context& context, const Buffer& src, size_t size, size_t srcOffset) {
  Buffer staging = createBuffer(context, size, VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::Readback, "readback");
  // barriers: callers' earlier submissions have completed (one-shot submits wait).
  context.submitAndWait([&](VkCommandBuffer cmd) {
    VkBufferCopy region{srcOffset, 0, size};
    vkCmdCopyBuffer(cmd, src.handle(), staging.handle(), 1, &region);
  });
  return std::vector<uint8_t>(staging.mapped(), staging.mapped() + size);
}

void uploadTextureRGBA8(Context& context, const Image& dst, const uint8_t* rgba, uint32_t width, uint32_t height,
                        uint32_t mipLevels) {
  size_t size = size_t(width) * height * 4;
  Buffer staging =
      createBuffer(context, size, VK_BUFFER_USAGE_TRANSFER_SRC_BIT, MemoryUsage::Upload, "texture staging");
  std::memcpy(staging.mapped(), rgba, size);
  context.submitAndWait([&](VkCommandBuffer cmd) {
    cmdImageBarrier(cmd,
                    {dst.handle(), VK_PIPELINE_STAGE_2_NONE, 0, VK_PIPELINE_STAGE_2_TRANSFER_BIT,
                     VK_ACCESS_2_TRANSFER_WRITE_BIT, VK_IMAGE_LAYOUT_UNDEFINED, VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL});
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {width, height, 1};
    vkCmdCopyBufferToImage(cmd, staging.handle(), dst.handle(), VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &region);
    // Each mip is blitted from the one above: mip i-1 goes to TRANSFER_SRC before it is read.
    int32_t w = int32_t(width), h = int32_t(height);
    for (uint32_t mip = 1; mip < mipLevels; ++mip) {
      cmdImageBarrier(cmd, {dst.handle(), VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                            VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT,
                            VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL,
                            VK_IMAGE_ASPECT_COLOR_BIT, /*baseMip=*/mip - 1, /*mipLevels=*/1});
      VkImageBlit blit{};
      blit.srcSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, mip - 1, 0, 1};
      blit.srcOffsets[1] = {w, h, 1};
      w = std::max(1, w / 2);
      h = std::max(1, h / 2);
      blit.dstSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, mip, 0, 1};
      blit.dstOffsets[1] = {w, h, 1};
      vkCmdBlitImage(cmd, dst.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, dst.handle(),
                     VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL, 1, &blit, VK_FILTER_LINEAR);
    }
    // Mips 0..n-2 are TRANSFER_SRC, the last is TRANSFER_DST: move each to shader-read.
    std::vector<ImageBarrier> finals;
    for (uint32_t mip = 0; mip < mipLevels; ++mip)
      finals.push_back(
          {dst.handle(), VK_PIPELINE_STAGE_2_TRANSFER_BIT,
           VK_ACCESS_2_TRANSFER_WRITE_BIT | VK_ACCESS_2_TRANSFER_READ_BIT,
           VK_PIPELINE_STAGE_2_FRAGMENT_SHADER_BIT | VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT,
           VK_ACCESS_2_SHADER_SAMPLED_READ_BIT,
           mip + 1 < mipLevels ? VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL : VK_IMAGE_LAYOUT_TRANSFER_DST_OPTIMAL,
           VK_IMAGE_LAYOUT_SHADER_READ_ONLY_OPTIMAL, VK_IMAGE_ASPECT_COLOR_BIT, mip, 1});
    cmdImageBarriers(cmd, finals);
  });
}

std::vector<uint8_t> readbackImage(Context& context, const Image& src, VkImageLayout layout, uint32_t bytesPerPixel) {
  VkExtent3D e = src.extent();
  size_t size = size_t(e.width) * e.height * bytesPerPixel;
  Buffer staging =
      createBuffer(context, size, VK_BUFFER_USAGE_TRANSFER_DST_BIT, MemoryUsage::Readback, "image readback");
  // barriers: the image was last written as a color attachment or by compute, then read back here.
  context.submitAndWait([&](VkCommandBuffer cmd) {
    cmdImageBarrier(cmd, {src.handle(), VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_WRITE_BIT,
                          VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT, layout,
                          VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL});
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = e;
    vkCmdCopyImageToBuffer(cmd, src.handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, staging.handle(), 1, &region);
    cmdImageBarrier(cmd,
                    {src.handle(), VK_PIPELINE_STAGE_2_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT,
                     VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT, VK_ACCESS_2_MEMORY_READ_BIT | VK_ACCESS_2_MEMORY_WRITE_BIT,
                     VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, layout});
  });
  return std::vector<uint8_t>(staging.mapped(), staging.mapped() + size);
}

} // namespace mirage::gpu
