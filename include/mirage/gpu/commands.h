#pragma once
// Synchronization2 barrier helpers (niagara's stageBarrier/imageBarrier) and blocking transfers.
#include <span>
#include <vector>

#include "mirage/gpu/memory.h"

namespace mirage::gpu {

class Context;

// Work groups a dispatch may have per dimension on every device: the smallest
// maxComputeWorkGroupCount Vulkan allows. Larger counts split into rows (y) or several dispatches.
constexpr uint32_t kMaxDispatchGroups = 65535;

// A 1D count of work groups as (x, y) rows with x <= kMaxDispatchGroups; shaders index
// gl_WorkGroupID.y * gl_NumWorkGroups.x + gl_WorkGroupID.x and skip the last row's excess.
struct DispatchRows {
  uint32_t x = 0, y = 0;
};
inline DispatchRows dispatchRows(uint32_t groups) {
  return {groups < kMaxDispatchGroups ? groups : kMaxDispatchGroups,
          (groups + kMaxDispatchGroups - 1) / kMaxDispatchGroups};
}

struct ImageBarrier {
  VkImage image = VK_NULL_HANDLE;
  VkPipelineStageFlags2 srcStage = VK_PIPELINE_STAGE_2_NONE;
  VkAccessFlags2 srcAccess = 0;
  VkPipelineStageFlags2 dstStage = VK_PIPELINE_STAGE_2_NONE;
  VkAccessFlags2 dstAccess = 0;
  VkImageLayout oldLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  VkImageLayout newLayout = VK_IMAGE_LAYOUT_UNDEFINED;
  VkImageAspectFlags aspect = VK_IMAGE_ASPECT_COLOR_BIT;
  uint32_t baseMip = 0;
  uint32_t mipLevels = VK_REMAINING_MIP_LEVELS;
  uint32_t layers = VK_REMAINING_ARRAY_LAYERS;
};

void cmdImageBarriers(VkCommandBuffer cmd, std::span<const ImageBarrier> barriers);
inline void cmdImageBarrier(VkCommandBuffer cmd, const ImageBarrier& b) { cmdImageBarriers(cmd, {&b, 1}); }
// Viewport (depth 0..1) and scissor covering a width x height target: the dynamic state every
// full-target draw sets.
void cmdSetFullViewport(VkCommandBuffer cmd, uint32_t width, uint32_t height);
// A global memory barrier: everything `srcStage` wrote with `srcAccess` is visible to `dstStage`/`dstAccess`.
void cmdMemoryBarrier(VkCommandBuffer cmd, VkPipelineStageFlags2 srcStage, VkAccessFlags2 srcAccess,
                      VkPipelineStageFlags2 dstStage, VkAccessFlags2 dstAccess);

// Blocking transfers through a temporary staging buffer (set-up time, not the frame loop).
void uploadBuffer(Context& context, const Buffer& dst, const void* data, size_t size, size_t dstOffset = 0);
template <class T>
Buffer createBufferWithData(Context& context, std::span<const T> data, VkBufferUsageFlags usage, const char* name) {
  Buffer b = createBuffer(context, std::max<size_t>(data.size_bytes(), 4), usage | VK_BUFFER_USAGE_TRANSFER_DST_BIT,
                          MemoryUsage::GpuOnly, name);
  if (!data.empty()) uploadBuffer(context, b, data.data(), data.size_bytes());
  return b;
}
std::vector<uint8_t> readbackBuffer(Context& context, const Buffer& src, size_t size, size_t srcOffset = 0);
// Upload RGBA8 pixels into mip 0 of `dst`, generate the mip chain by blits, and leave every mip in
// SHADER_READ_ONLY_OPTIMAL for fragment shaders.
void uploadTextureRGBA8(Context& context, const Image& dst, const uint8_t* rgba, uint32_t width, uint32_t height,
                        uint32_t mipLevels);
// Copy a color image (in `layout`) to host memory; bytesPerPixel matches the format.
std::vector<uint8_t> readbackImage(Context& context, const Image& src, VkImageLayout layout, uint32_t bytesPerPixel);

uint32_t mipLevelCount(uint32_t width, uint32_t height);

} // namespace mirage::gpu
