#pragma once
// Vulkan through volk (function pointers loaded at run time), plus the one-owner RAII handle every
// Mirage Vulkan object lives in, and VK_CHECK for results that indicate a programming error.
#include <volk.h>

#include <cstdio>
#include <cstdlib>
#include <utility>

namespace mirage::gpu {

const char* toString(VkResult result);

// An unexpected VkResult is a bug or a lost device: abort with file:line (niagara's VK_CHECK).
#define MIRAGE_VK_CHECK(call)                                                                                          \
  do {                                                                                                                 \
    VkResult mirage_vk_result_ = (call);                                                                               \
    if (mirage_vk_result_ < 0) {                                                                                       \
      std::fprintf(stderr, "mirage: fatal: %s:%d: %s returned %s\n", __FILE__, __LINE__, #call,                        \
                   ::mirage::gpu::toString(mirage_vk_result_));                                                        \
      std::abort();                                                                                                    \
    }                                                                                                                  \
  } while (0)

// Destroy functions found by overload on the (distinct, 64-bit) handle types.
inline void destroyHandle(VkDevice d, VkBuffer h) { vkDestroyBuffer(d, h, nullptr); }
inline void destroyHandle(VkDevice d, VkImage h) { vkDestroyImage(d, h, nullptr); }
inline void destroyHandle(VkDevice d, VkImageView h) { vkDestroyImageView(d, h, nullptr); }
inline void destroyHandle(VkDevice d, VkSampler h) { vkDestroySampler(d, h, nullptr); }
inline void destroyHandle(VkDevice d, VkDeviceMemory h) { vkFreeMemory(d, h, nullptr); }
inline void destroyHandle(VkDevice d, VkShaderModule h) { vkDestroyShaderModule(d, h, nullptr); }
inline void destroyHandle(VkDevice d, VkPipeline h) { vkDestroyPipeline(d, h, nullptr); }
inline void destroyHandle(VkDevice d, VkPipelineLayout h) { vkDestroyPipelineLayout(d, h, nullptr); }
inline void destroyHandle(VkDevice d, VkDescriptorSetLayout h) { vkDestroyDescriptorSetLayout(d, h, nullptr); }
inline void destroyHandle(VkDevice d, VkDescriptorPool h) { vkDestroyDescriptorPool(d, h, nullptr); }
inline void destroyHandle(VkDevice d, VkCommandPool h) { vkDestroyCommandPool(d, h, nullptr); }
inline void destroyHandle(VkDevice d, VkFence h) { vkDestroyFence(d, h, nullptr); }
inline void destroyHandle(VkDevice d, VkSemaphore h) { vkDestroySemaphore(d, h, nullptr); }
inline void destroyHandle(VkDevice d, VkQueryPool h) { vkDestroyQueryPool(d, h, nullptr); }
inline void destroyHandle(VkDevice d, VkSwapchainKHR h) { vkDestroySwapchainKHR(d, h, nullptr); }
inline void destroyHandle(VkDevice d, VkAccelerationStructureKHR h) {
  vkDestroyAccelerationStructureKHR(d, h, nullptr);
}

// Move-only owner of one device-level handle. Destruction is immediate: Mirage's renderers wait for
// their submissions before they release resources (a frame-deferred delete queue comes with
// multi-frame streaming).
template <class T> class Unique {
public:
  Unique() = default;
  Unique(VkDevice device, T handle) : device_(device), handle_(handle) {}
  Unique(Unique&& o) noexcept : device_(o.device_), handle_(std::exchange(o.handle_, VK_NULL_HANDLE)) {}
  Unique& operator=(Unique&& o) noexcept {
    if (this != &o) {
      reset();
      device_ = o.device_;
      handle_ = std::exchange(o.handle_, VK_NULL_HANDLE);
    }
    return *this;
  }
  Unique(const Unique&) = delete;
  Unique& operator=(const Unique&) = delete;
  ~Unique() { reset(); }

  void reset() {
    if (handle_ != VK_NULL_HANDLE) destroyHandle(device_, handle_);
    handle_ = VK_NULL_HANDLE;
  }
  T get() const { return handle_; }
  operator T() const { return handle_; }
  explicit operator bool() const { return handle_ != VK_NULL_HANDLE; }
  const T* ptr() const { return &handle_; }

private:
  VkDevice device_ = VK_NULL_HANDLE;
  T handle_ = VK_NULL_HANDLE;
};

} // namespace mirage::gpu
