#pragma once
// GPU test fixture: one Vulkan context per test process with validation layers (and synchronization
// validation) on; a test fails when it caused any validation warning or error.
#include <gtest/gtest.h>

#include <chrono>
#include <condition_variable>
#include <cstring>
#include <functional>
#include <memory>
#include <mutex>
#include <span>
#include <thread>
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

// The frames-in-flight tests' loop, a viewer's without waits: slots 0..sizes.size()-1 each get a
// command buffer in which `record` records the frame and the top-left sizes[slot] of its colour
// target is copied out (as a swapchain blit would), submitted with the slot's own fence; one wait
// for all at the end. Returns each slot's pixels as half floats, or nothing after a failure (the
// test is told which).
// With `gateFirstFrame` the first frame's submit also waits for a timeline semaphore that the host
// signals only once every frame was recorded and submitted: a record that waits for the device
// (vkDeviceWaitIdle, a one-shot submit and wait) would wait forever. A watchdog signals it after
// two minutes instead and the test fails saying a record waited.
inline std::vector<std::vector<uint16_t>> recordFramesInFlight(gpu::Context& ctx, std::span<const VkExtent2D> sizes,
                                                               const RecordFrame& record, bool gateFirstFrame = false) {
  VkDevice device = ctx.device();
  const uint32_t frames = uint32_t(sizes.size());
  struct Owned { // destroyed on every return, after the fences were waited for or never submitted
    VkDevice device;
    VkCommandPool pool = VK_NULL_HANDLE;
    std::vector<VkFence> fences;
    VkSemaphore gate = VK_NULL_HANDLE;
    ~Owned() {
      for (VkFence f : fences) vkDestroyFence(device, f, nullptr);
      if (pool) vkDestroyCommandPool(device, pool, nullptr);
      if (gate) vkDestroySemaphore(device, gate, nullptr);
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
  std::vector<gpu::Buffer> pixels;
  for (uint32_t i = 0; i < frames; ++i) {
    VkFenceCreateInfo fi{VK_STRUCTURE_TYPE_FENCE_CREATE_INFO};
    VkFence fence = VK_NULL_HANDLE;
    if (vkCreateFence(device, &fi, nullptr, &fence) != VK_SUCCESS) return failed("vkCreateFence");
    owned.fences.push_back(fence);
    pixels.push_back(gpu::createBuffer(ctx, uint64_t(sizes[i].width) * sizes[i].height * 8, // RGBA16F
                                       VK_BUFFER_USAGE_TRANSFER_DST_BIT, gpu::MemoryUsage::Readback, "frame pixels"));
  }
  if (gateFirstFrame) {
    VkSemaphoreTypeCreateInfo ti{VK_STRUCTURE_TYPE_SEMAPHORE_TYPE_CREATE_INFO};
    ti.semaphoreType = VK_SEMAPHORE_TYPE_TIMELINE;
    VkSemaphoreCreateInfo si{VK_STRUCTURE_TYPE_SEMAPHORE_CREATE_INFO};
    si.pNext = &ti;
    if (vkCreateSemaphore(device, &si, nullptr, &owned.gate) != VK_SUCCESS) return failed("vkCreateSemaphore");
  }
  // The gate opens once, from the watchdog or from here.
  std::mutex gateMutex;
  std::condition_variable gateOpened;
  bool open = !gateFirstFrame, stalled = false;
  auto openGate = [&](bool fromWatchdog) {
    std::lock_guard lock(gateMutex);
    if (open) return;
    open = true;
    stalled = fromWatchdog;
    VkSemaphoreSignalInfo signal{VK_STRUCTURE_TYPE_SEMAPHORE_SIGNAL_INFO};
    signal.semaphore = owned.gate;
    signal.value = 1;
    vkSignalSemaphore(device, &signal);
    gateOpened.notify_all();
  };
  std::thread watchdog;
  if (gateFirstFrame)
    watchdog = std::thread([&] {
      std::unique_lock lock(gateMutex);
      if (gateOpened.wait_for(lock, std::chrono::minutes(2), [&] { return open; })) return;
      lock.unlock();
      openGate(true);
    });
  struct Joiner { // the watchdog ends before the gate and the fences are destroyed
    std::thread& thread;
    ~Joiner() {
      if (thread.joinable()) thread.join();
    }
  } joiner{watchdog};
  uint32_t submitted = 0;
  auto waitSubmitted = [&] {
    openGate(false);
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
    region.imageExtent = {sizes[i].width, sizes[i].height, 1};
    vkCmdCopyImageToBuffer(cmds[i], color->handle(), VK_IMAGE_LAYOUT_TRANSFER_SRC_OPTIMAL, pixels[i].handle(), 1,
                           &region);
    gpu::cmdMemoryBarrier(cmds[i], VK_PIPELINE_STAGE_2_ALL_TRANSFER_BIT, VK_ACCESS_2_TRANSFER_WRITE_BIT,
                          VK_PIPELINE_STAGE_2_HOST_BIT, VK_ACCESS_2_HOST_READ_BIT);
    if (vkEndCommandBuffer(cmds[i]) != VK_SUCCESS) return waitSubmitted(), failed("vkEndCommandBuffer");
    VkCommandBufferSubmitInfo cbi{VK_STRUCTURE_TYPE_COMMAND_BUFFER_SUBMIT_INFO};
    cbi.commandBuffer = cmds[i];
    VkSemaphoreSubmitInfo gateWait{VK_STRUCTURE_TYPE_SEMAPHORE_SUBMIT_INFO};
    gateWait.semaphore = owned.gate;
    gateWait.value = 1;
    gateWait.stageMask = VK_PIPELINE_STAGE_2_ALL_COMMANDS_BIT;
    VkSubmitInfo2 si{VK_STRUCTURE_TYPE_SUBMIT_INFO_2};
    si.waitSemaphoreInfoCount = i == 0 && gateFirstFrame ? 1 : 0;
    si.pWaitSemaphoreInfos = &gateWait;
    si.commandBufferInfoCount = 1;
    si.pCommandBufferInfos = &cbi;
    if (vkQueueSubmit2(ctx.queue(), 1, &si, owned.fences[i]) != VK_SUCCESS)
      return waitSubmitted(), failed("vkQueueSubmit2");
    ++submitted;
  }
  openGate(false);
  if (watchdog.joinable()) watchdog.join();
  if (stalled) ADD_FAILURE() << "a record waited for the frames in flight before it (the gate opened by the watchdog)";
  if (vkWaitForFences(device, frames, owned.fences.data(), VK_TRUE, UINT64_MAX) != VK_SUCCESS)
    return failed("vkWaitForFences");
  std::vector<std::vector<uint16_t>> out(frames);
  for (uint32_t i = 0; i < frames; ++i) {
    out[i].resize(size_t(sizes[i].width) * sizes[i].height * 4);
    std::memcpy(out[i].data(), pixels[i].mapped(), out[i].size() * 2);
  }
  return out;
}

// Every frame width x height.
inline std::vector<std::vector<uint16_t>> recordFramesInFlight(gpu::Context& ctx, uint32_t frames, uint32_t width,
                                                               uint32_t height, const RecordFrame& record) {
  std::vector<VkExtent2D> sizes(frames, VkExtent2D{width, height});
  return recordFramesInFlight(ctx, sizes, record);
}

// Channel values of half-float pixels that differ from a float image's (which must be as long).
inline size_t differingChannels(const std::vector<uint16_t>& half, const std::vector<float>& linear) {
  EXPECT_EQ(half.size(), linear.size());
  size_t differing = 0;
  for (size_t k = 0; k < half.size() && k < linear.size(); ++k) differing += glm::unpackHalf1x16(half[k]) != linear[k];
  return differing;
}

} // namespace mirage::test
