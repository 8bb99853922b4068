#pragma once
// GPU test fixture: one Vulkan context per test process with validation layers (and synchronization
// validation) on; a test fails when it caused any validation warning or error.
#include <gtest/gtest.h>

#include <cstring>
#include <functional>
#include <memory>
#include <vector>

#include <glm/gtc/packing.hpp>

#include "mirage/gpu/commands.h"
#include "mirage/gpu/context.h"
#include "mirage/gpu/memory.h"

namespace mirage::test {

inline gpu::Context& gpuContext() {
  static std::unique_ptr<gpu::Context> context = [] {
    gpu::ContextOptions options;
    options.validation = true;
    auto r = gpu::Context::create(options);
    if (!r) {
      std::fprintf(stderr, "cannot create a Vulkan context: %s\n", r.error().message.c_str());
      std::abort();
    }
    return std::move(r).value();
  }();
  return *context;
}

class GpuTest : public ::testing::Test {
protected:
  void SetUp() override { issuesBefore_ = gpuContext().validationIssues(); }
  void TearDown() override {
    const auto& ctx = gpuContext();
    if (ctx.validationIssues() != issuesBefore_) {
      std::string all;
      for (size_t i = issuesBefore_; i < ctx.validationMessages().size(); ++i)
        all += ctx.validationMessages()[i] + "\n";
      ADD_FAILURE() << "validation layer reported " << (ctx.validationIssues() - issuesBefore_) << " issue(s):\n"
                    << all;
    }
  }
  gpu::Context& context() { return gpuContext(); }

private:
  uint32_t issuesBefore_ = 0;
};

// Records the frame of slot `cmd`/`slot` and names its colour target (RGBA16F, left in GENERAL by
// compute writes); a failure is returned as is.
using RecordFrame = std::function<Status(VkCommandBuffer cmd, uint32_t slot, const gpu::Image*& color)>;

// The frames-in-flight tests' loop, a viewer's without waits: slots 0..frames-1 each get a command
// buffer in which `record` records the frame and its colour target (width x height) is copied out
// (as a swapchain blit would), submitted with the slot's own fence; one wait for all at the end.
// Returns each slot's pixels as half floats, or nothing after a failure (the test is told which).
inline std::vector<std::vector<uint16_t>> recordFramesInFlight(gpu::Context& ctx, uint32_t frames, uint32_t width,
                                                               uint32_t height, const RecordFrame& record) {
  VkDevice device = ctx.device();
  struct Owned { // destroyed on every return, after the fences were waited for or never submitted
    VkDevice device;
    VkCommandPool pool = VK_NULL_HANDLE;
    std::vector<VkFence> fences;
    ~Owned() {
      for (VkFence f : fences) vkDestroyFence(device, f, nullptr);
      if (pool) vkDestroyCommandPool(device, pool, nullptr);
    }
  } owned{device};
  auto failed = [](const std::string& what) {
    ADD_FAILURE() << what;
    return std::vector<std::vector<uint16_t>>{};
  };
  VkCommandPoolCreateInfo pi{VK_STRUCTURE_TYPE_COMMAND_POOL_CREATE_INFO};
  pi.queueFamilyIndex = ctx.queueFamily();
  if (vkCreateCommandPool(device, &pi, nullptr, &owned.pool) != VK_SUCCESS) return failed("vkCreateCommandPool");
  std::vector<VkCommandBuffer> cmds(frames);
  VkCommandBufferAllocateInfo ai{VK_STRUCTURE_TYPE_COMMAND_BUFFER_ALLOCATE_INFO};
  ai.commandPool = owned.pool;
  ai.level = VK_COMMAND_BUFFER_LEVEL_PRIMARY;
  ai.commandBufferCount = frames;
  if (vkAllocateCommandBuffers(device, &ai, cmds.data()) != VK_SUCCESS) return failed("vkAllocateCommandBuffers");
  const uint64_t bytes = uint64_t(width) * height * 8; // RGBA16F
  std::vector<gpu::Buffer> pixels;
  for (uint32_t i = 0; i < frames; ++i) {
    VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    VkFence fence = VK_NULL_HANDLE;
    if (vkCreateFence(device, &fi, nullptr, &fence) != VK_SUCCESS) return failed("vkCreateFence");
    owned.fences.push_back(fence);
    pixels.push_back(
        gpu::createBuffer(ctx, bytes, VK_BUFFER_USAGE_TRANSFER_DST_BIT, gpu::MemoryUsage::Readback, "frame pixels"));
  }
  uint32_t submitted = 0;
  auto waitSubmitted = [&] {
    if (submitted) vkWaitForFences(device, submitted, owned.fences.data(), VK_TRUE, UINT64_MAX);
  };
  for (uint32_t i = 0; i < frames; ++i) {
    VkCommandBufferBeginInfo bi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_BEGIN_INFO};
    bi.flags = VK_COMMAND_BUFFER_USAGE_ONE_TIME_SUBMIT_BIT;
    if (vkBeginCommandBuffer(cmds[i], &bi) != VK_SUCCESS) return waitSubmitted(), failed("vkBeginCommandBuffer");
    const gpu::Image* color = nullptr;
    if (Status recorded = record(cmds[i], i, color); !recorded)
      return waitSubmitted(), failed("record slot " + std::to_string(i) + ": " + recorded.error().message);
    if (!color || color->format() != VK_FORMAT_R16G16B16A16_SFLOAT)
      return waitSubmitted(), failed("slot " + std::to_string(i) + ": no RGBA16F colour target");
    gpu::cmdImageBarrier(cmds[i],
                         {color->handle(), VK_PIPELINE_STAGE_2_COMPUTE_SHADER_BIT, VK_ACCESS_2_SHADER_STORAGE_WRITE_BIT,
                          VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_READ_BIT, VK_IMAGE_LAYOUT_GENERAL,
                          VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL});
    VkBufferImageCopy region{};
    region.imageSubresource = {VK_IMAGE_ASPECT_COLOR_BIT, 0, 0, 1};
    region.imageExtent = {width, height, 1};
    vkCmdCopyImageToBuffer(cmds[i], color->handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, pixels[i].handle(), 1,
                           &region);
    gpu::cmdMemoryBarrier(cmds[i], VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                          VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
    if (vkEndCommandBuffer(cmds[i]) != VK_SUCCESS) return waitSubmitted(), failed("vkEndCommandBuffer");
    VkCommandBufferSubmitInfo cbi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO};
    cbi.commandBuffer = cmds[i];
    VkSubmitInfo2 si{VK_STRUCTURE_TYPE_SUBMIT_INFO_2};
    si.commandBufferInfoCount = 1;
    si.pCommandBufferInfos = &cbi;
    if (vkQueueSubmit2(ctx.queue(), 1, &si, owned.fences[i]) != VK_SUCCESS)
      return waitSubmitted(), failed("vkQueueSubmit2");
    ++submitted;
  }
  if (vkWaitForFences(device, frames, owned.fences.data(), VK_TRUE, UINT64_MAX) != VK_SUCCESS)
    return failed("vkWaitForFences");
  std::vector<std::vector<uint16_t>> out(frames, std::vector<uint16_t>(size_t(bytes / 2)));
  for (uint32_t i = 0; i < frames; ++i) std::memcpy(out[i].data(), pixels[i].mapped(), bytes);
  return out;
}

// Channel values of half-float pixels that differ from a float image's (which must be as long).
inline size_t differingChannels(const std::vector<uint16_t>& half, const std::vector<float>& linear) {
  EXPECT_EQ(half.size(), linear.size());
  size_t differing = 0;
  for (size_t k = 0; k < half.size() && k < linear.size(); ++k) differing += glm::unpackHalf1x16(half[k]) != linear[k];
  return differing;
}

} // namespace mirage::test
